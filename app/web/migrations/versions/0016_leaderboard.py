"""The leaderboard: seasons, submitters, systems and rounds (app.web.board.models).

Revision ID: 0016_leaderboard
Revises: 0015_stimulus_webm
Create Date: 2026-12-07 07:30:00

"""

import sqlalchemy as sa
from alembic import op

revision = "0016_leaderboard"
down_revision = "0015_stimulus_webm"
branch_labels = None
depends_on = None


def upgrade():
    op.create_table(
        "board_season",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("name", sa.String(length=64), nullable=False),
        sa.Column("title", sa.String(length=200), nullable=False),
        sa.Column("organiser_id", sa.Integer(), nullable=False),
        sa.Column("status", sa.String(length=10), nullable=False),
        sa.Column("source_toml", sa.Text(), nullable=False),
        sa.Column("settings", sa.JSON(), nullable=False),
        sa.Column("manifest", sa.JSON(), nullable=False),
        sa.Column("manifest_sha256", sa.String(length=64), nullable=False),
        sa.Column("draw_seed", sa.BigInteger(), nullable=False),
        sa.Column("anchors_study_id", sa.Integer(), nullable=True),
        sa.Column("board", sa.JSON(), nullable=True),
        sa.Column("published_at", sa.DateTime(), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["anchors_study_id"],
            ["study.id"],
            name=op.f("fk_board_season_anchors_study_id_study"),
            ondelete="SET NULL",
        ),
        sa.ForeignKeyConstraint(
            ["organiser_id"], ["user.id"], name=op.f("fk_board_season_organiser_id_user")
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_board_season")),
        sa.UniqueConstraint("name", name=op.f("uq_board_season_name")),
    )
    with op.batch_alter_table("board_season", schema=None) as batch_op:
        batch_op.create_index(
            batch_op.f("ix_board_season_organiser_id"), ["organiser_id"], unique=False
        )

    op.create_table(
        "board_submitter",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("season_id", sa.Integer(), nullable=False),
        sa.Column("team", sa.String(length=200), nullable=False),
        sa.Column("contact", sa.String(length=200), nullable=False),
        sa.Column("key_hash", sa.String(length=64), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["season_id"],
            ["board_season.id"],
            name=op.f("fk_board_submitter_season_id_board_season"),
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_board_submitter")),
        sa.UniqueConstraint("key_hash", name=op.f("uq_board_submitter_key_hash")),
    )
    with op.batch_alter_table("board_submitter", schema=None) as batch_op:
        batch_op.create_index(
            batch_op.f("ix_board_submitter_season_id"), ["season_id"], unique=False
        )

    op.create_table(
        "board_system",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("season_id", sa.Integer(), nullable=False),
        sa.Column("code", sa.String(length=16), nullable=False),
        sa.Column("name", sa.String(length=80), nullable=False),
        sa.Column("kind", sa.String(length=10), nullable=False),
        sa.Column("model", sa.String(length=80), nullable=False),
        sa.Column("status", sa.String(length=12), nullable=False),
        sa.Column("submitter_id", sa.Integer(), nullable=True),
        sa.Column("paper", sa.String(length=500), nullable=False),
        sa.Column("training_data", sa.Text(), nullable=False),
        sa.Column("licence", sa.String(length=80), nullable=False),
        sa.Column("licence_granted_at", sa.DateTime(), nullable=True),
        sa.Column("anonymous_name", sa.String(length=80), nullable=True),
        sa.Column("anonymous_until", sa.Date(), nullable=True),
        sa.Column("check", sa.JSON(), nullable=False),
        sa.Column("files", sa.JSON(), nullable=False),
        sa.Column("objective", sa.JSON(), nullable=True),
        sa.Column("preview_token", sa.String(length=64), nullable=False),
        sa.Column("preview_study_id", sa.Integer(), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.Column("queued_at", sa.DateTime(), nullable=True),
        sa.ForeignKeyConstraint(
            ["preview_study_id"],
            ["study.id"],
            name=op.f("fk_board_system_preview_study_id_study"),
            ondelete="SET NULL",
        ),
        sa.ForeignKeyConstraint(
            ["season_id"], ["board_season.id"], name=op.f("fk_board_system_season_id_board_season")
        ),
        sa.ForeignKeyConstraint(
            ["submitter_id"],
            ["board_submitter.id"],
            name=op.f("fk_board_system_submitter_id_board_submitter"),
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_board_system")),
        sa.UniqueConstraint("preview_token", name=op.f("uq_board_system_preview_token")),
        sa.UniqueConstraint("season_id", "code", name=op.f("uq_board_system_season_id_code")),
        sa.UniqueConstraint("season_id", "name", name=op.f("uq_board_system_season_id_name")),
    )

    op.create_table(
        "board_round",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("season_id", sa.Integer(), nullable=False),
        sa.Column("number", sa.Integer(), nullable=False),
        sa.Column("status", sa.String(length=12), nullable=False),
        sa.Column("study_id", sa.Integer(), nullable=False),
        sa.Column("systems", sa.JSON(), nullable=False),
        sa.Column("newcomers", sa.JSON(), nullable=False),
        sa.Column("anchors", sa.JSON(), nullable=False),
        sa.Column("segments", sa.JSON(), nullable=False),
        sa.Column("plan", sa.JSON(), nullable=False),
        sa.Column("drift", sa.JSON(), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.Column("published_at", sa.DateTime(), nullable=True),
        sa.ForeignKeyConstraint(
            ["season_id"], ["board_season.id"], name=op.f("fk_board_round_season_id_board_season")
        ),
        sa.ForeignKeyConstraint(
            ["study_id"], ["study.id"], name=op.f("fk_board_round_study_id_study")
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_board_round")),
        sa.UniqueConstraint("season_id", "number", name=op.f("uq_board_round_season_id_number")),
    )
    with op.batch_alter_table("board_round", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_board_round_study_id"), ["study_id"], unique=False)


def downgrade():
    with op.batch_alter_table("board_round", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_board_round_study_id"))
    op.drop_table("board_round")
    op.drop_table("board_system")
    with op.batch_alter_table("board_submitter", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_board_submitter_season_id"))
    op.drop_table("board_submitter")
    with op.batch_alter_table("board_season", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_board_season_organiser_id"))
    op.drop_table("board_season")
