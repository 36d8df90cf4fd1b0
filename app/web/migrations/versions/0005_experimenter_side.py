"""The experimenter's side: pilot links, participant exclusions, questionnaire answers,
studies shared with collaborators.

Reviewed by hand: every existing study is given its own random pilot token before the column
becomes NOT NULL and unique; the participant columns have server defaults, so existing rows
read as real (not pilot), not excluded participants; batch mode keeps SQLite happy.

Revision ID: 0005_experimenter_side
Revises: 0004_participant_side
Create Date: 2026-12-01 02:00:00

"""

import secrets

import sqlalchemy as sa
from alembic import op

revision = "0005_experimenter_side"
down_revision = "0004_participant_side"
branch_labels = None
depends_on = None


def upgrade():
    with op.batch_alter_table("study", schema=None) as batch_op:
        batch_op.add_column(sa.Column("pilot_token", sa.String(length=64), nullable=True))
    study = sa.table(
        "study", sa.column("id", sa.Integer()), sa.column("pilot_token", sa.String(length=64))
    )
    connection = op.get_bind()
    for (study_id,) in connection.execute(sa.select(study.c.id)).all():
        connection.execute(
            sa.update(study)
            .where(study.c.id == study_id)
            .values(pilot_token=secrets.token_urlsafe(24))
        )
    with op.batch_alter_table("study", schema=None) as batch_op:
        batch_op.alter_column("pilot_token", existing_type=sa.String(length=64), nullable=False)
        batch_op.create_unique_constraint(batch_op.f("uq_study_pilot_token"), ["pilot_token"])
    with op.batch_alter_table("participant", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("pilot", sa.Boolean(), server_default=sa.false(), nullable=False)
        )
        batch_op.add_column(sa.Column("excluded_at", sa.DateTime(), nullable=True))
        batch_op.add_column(
            sa.Column("exclusion_reason", sa.String(length=300), server_default="", nullable=False)
        )
        batch_op.add_column(sa.Column("answers", sa.JSON(), nullable=True))
    op.create_table(
        "study_share",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("study_id", sa.Integer(), nullable=False),
        sa.Column("user_id", sa.Integer(), nullable=False),
        sa.Column("access", sa.String(length=10), nullable=False),
        sa.ForeignKeyConstraint(
            ["study_id"], ["study.id"], name=op.f("fk_study_share_study_id_study")
        ),
        sa.ForeignKeyConstraint(["user_id"], ["user.id"], name=op.f("fk_study_share_user_id_user")),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_study_share")),
        sa.UniqueConstraint("study_id", "user_id", name=op.f("uq_study_share_study_id_user_id")),
    )
    with op.batch_alter_table("study_share", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_study_share_study_id"), ["study_id"], unique=False)
        batch_op.create_index(batch_op.f("ix_study_share_user_id"), ["user_id"], unique=False)


def downgrade():
    op.drop_table("study_share")
    with op.batch_alter_table("participant", schema=None) as batch_op:
        batch_op.drop_column("answers")
        batch_op.drop_column("exclusion_reason")
        batch_op.drop_column("excluded_at")
        batch_op.drop_column("pilot")
    with op.batch_alter_table("study", schema=None) as batch_op:
        batch_op.drop_constraint(batch_op.f("uq_study_pilot_token"), type_="unique")
        batch_op.drop_column("pilot_token")
