"""The participant's side: plays counted by the server, the media log and answer details of
each vote, the participant's environment and attention screening, one enrolment per Prolific
ID, and the stimulus variants for attention checks and appropriateness pairs.

Reviewed by hand: every new column is nullable or has a server default, so existing rows stay
valid; the stimulus key gains the two variant columns; batch mode keeps SQLite happy. The
unique Prolific ID per study would fail on a database that already holds duplicates: resolve
those (``facepair`` keeps the first) before upgrading.

Revision ID: 0004_participant_side
Revises: 0003_pseudonym_key
Create Date: 2026-12-01 02:00:00

"""

import sqlalchemy as sa
from alembic import op

revision = "0004_participant_side"
down_revision = "0003_pseudonym_key"
branch_labels = None
depends_on = None

VOTE_COLUMNS = (
    ("strength", sa.Integer()),
    ("reasons", sa.JSON()),
    ("watched_ms", sa.Integer()),
    ("played_to_end", sa.Boolean()),
    ("stalls", sa.Integer()),
    ("stall_ms", sa.Integer()),
    ("focus_lost", sa.Integer()),
    ("media", sa.JSON()),
)


def upgrade():
    with op.batch_alter_table("participant", schema=None) as batch_op:
        batch_op.add_column(sa.Column("screened_out_at", sa.DateTime(), nullable=True))
        batch_op.add_column(sa.Column("environment", sa.JSON(), nullable=True))
        batch_op.create_unique_constraint(
            batch_op.f("uq_participant_study_id_prolific_pid"), ["study_id", "prolific_pid"]
        )
    with op.batch_alter_table("trial", schema=None) as batch_op:
        batch_op.add_column(sa.Column("plays", sa.Integer(), nullable=False, server_default="0"))
    with op.batch_alter_table("vote", schema=None) as batch_op:
        for name, kind in VOTE_COLUMNS:
            batch_op.add_column(sa.Column(name, kind, nullable=True))
    with op.batch_alter_table("stimulus", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("instruction", sa.String(length=10), nullable=False, server_default="")
        )
        batch_op.add_column(
            sa.Column("foreign_side", sa.String(length=10), nullable=False, server_default="")
        )
        batch_op.add_column(sa.Column("foreign_clip_id", sa.Integer(), nullable=True))
        batch_op.create_foreign_key(
            batch_op.f("fk_stimulus_foreign_clip_id_clip"), "clip", ["foreign_clip_id"], ["id"]
        )
        batch_op.drop_constraint("uq_stimulus_clip_id_left_id_right_id", type_="unique")
        batch_op.create_unique_constraint(
            batch_op.f("uq_stimulus_clip_id_left_id_right_id_instruction_foreign_side"),
            ["clip_id", "left_id", "right_id", "instruction", "foreign_side"],
        )
    # The defaults only filled existing rows; the models give every new row its value.
    with op.batch_alter_table("trial", schema=None) as batch_op:
        batch_op.alter_column("plays", server_default=None)
    with op.batch_alter_table("stimulus", schema=None) as batch_op:
        batch_op.alter_column("instruction", server_default=None)
        batch_op.alter_column("foreign_side", server_default=None)


def downgrade():
    with op.batch_alter_table("stimulus", schema=None) as batch_op:
        batch_op.drop_constraint(
            "uq_stimulus_clip_id_left_id_right_id_instruction_foreign_side", type_="unique"
        )
        batch_op.create_unique_constraint(
            "uq_stimulus_clip_id_left_id_right_id", ["clip_id", "left_id", "right_id"]
        )
        batch_op.drop_constraint("fk_stimulus_foreign_clip_id_clip", type_="foreignkey")
        batch_op.drop_column("foreign_clip_id")
        batch_op.drop_column("foreign_side")
        batch_op.drop_column("instruction")
    with op.batch_alter_table("vote", schema=None) as batch_op:
        for name, _kind in reversed(VOTE_COLUMNS):
            batch_op.drop_column(name)
    with op.batch_alter_table("trial", schema=None) as batch_op:
        batch_op.drop_column("plays")
    with op.batch_alter_table("participant", schema=None) as batch_op:
        batch_op.drop_constraint("uq_participant_study_id_prolific_pid", type_="unique")
        batch_op.drop_column("environment")
        batch_op.drop_column("screened_out_at")
