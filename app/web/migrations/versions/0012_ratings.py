"""Ratings of the rating design (ITU-T P.910 ACR or a 0-100 slider): one row per participant,
trial and rated condition, stored exactly once (unique per trial and condition, and per
idempotency key and condition).

Revision ID: 0012_ratings
Revises: 0011_experimenter_records
Create Date: 2026-12-05 23:10:00

"""

import sqlalchemy as sa
from alembic import op

revision = "0012_ratings"
down_revision = "0011_experimenter_records"
branch_labels = None
depends_on = None


def upgrade():
    op.create_table(
        "rating",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("participant_id", sa.Integer(), nullable=False),
        sa.Column("trial_id", sa.Integer(), nullable=False),
        sa.Column("condition_id", sa.Integer(), nullable=False),
        sa.Column("idempotency_key", sa.String(length=64), nullable=False),
        sa.Column("score", sa.Integer(), nullable=False),
        sa.Column("response_ms", sa.Integer(), nullable=True),
        sa.Column("plays", sa.Integer(), nullable=False),
        sa.Column("presented_at", sa.DateTime(), nullable=True),
        sa.Column("rated_at", sa.DateTime(), nullable=False),
        sa.Column("watched_ms", sa.Integer(), nullable=True),
        sa.Column("played_to_end", sa.Boolean(), nullable=True),
        sa.Column("stalls", sa.Integer(), nullable=True),
        sa.Column("stall_ms", sa.Integer(), nullable=True),
        sa.Column("focus_lost", sa.Integer(), nullable=True),
        sa.Column("media", sa.JSON(), nullable=True),
        sa.CheckConstraint("score BETWEEN 0 AND 100", name=op.f("ck_rating_score")),
        sa.ForeignKeyConstraint(
            ["condition_id"], ["condition.id"], name=op.f("fk_rating_condition_id_condition")
        ),
        sa.ForeignKeyConstraint(
            ["participant_id"],
            ["participant.id"],
            name=op.f("fk_rating_participant_id_participant"),
        ),
        sa.ForeignKeyConstraint(["trial_id"], ["trial.id"], name=op.f("fk_rating_trial_id_trial")),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_rating")),
        sa.UniqueConstraint(
            "idempotency_key",
            "condition_id",
            name=op.f("uq_rating_idempotency_key_condition_id"),
        ),
        sa.UniqueConstraint(
            "participant_id",
            "trial_id",
            "condition_id",
            name=op.f("uq_rating_participant_id_trial_id_condition_id"),
        ),
    )
    with op.batch_alter_table("rating", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_rating_trial_id"), ["trial_id"], unique=False)


def downgrade():
    with op.batch_alter_table("rating", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_rating_trial_id"))
    op.drop_table("rating")
