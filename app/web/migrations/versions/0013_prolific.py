"""Recruiting on Prolific: the Prolific study made for a study (and the pilot's draft), the
outbox of calls that change something at Prolific (written before sending, each under a unique
idempotency key, claimed by one sender), the submissions as Prolific reports them, and the
webhook events received (unique by their X-Event-ID). No column holds the API token or the
webhook secret.

Revision ID: 0013_prolific
Revises: 0012_ratings
Create Date: 2026-12-07 06:10:00

"""

import sqlalchemy as sa
from alembic import op

revision = "0013_prolific"
down_revision = "0012_ratings"
branch_labels = None
depends_on = None


def upgrade():
    op.create_table(
        "prolific_event",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("event_id", sa.String(length=100), nullable=False),
        sa.Column("event_type", sa.String(length=60), nullable=False),
        sa.Column("resource_id", sa.String(length=64), nullable=False),
        sa.Column("status", sa.String(length=30), nullable=False),
        sa.Column("sent_at", sa.DateTime(), nullable=True),
        sa.Column("received_at", sa.DateTime(), nullable=False),
        sa.Column("outcome", sa.String(length=200), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_prolific_event")),
        sa.UniqueConstraint("event_id", name=op.f("uq_prolific_event_event_id")),
    )
    op.create_table(
        "prolific_call",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("study_id", sa.Integer(), nullable=False),
        sa.Column("kind", sa.String(length=20), nullable=False),
        sa.Column("key", sa.String(length=200), nullable=False),
        sa.Column("target", sa.String(length=64), nullable=False),
        sa.Column("payload", sa.JSON(), nullable=False),
        sa.Column("state", sa.String(length=12), nullable=False),
        sa.Column("attempts", sa.Integer(), nullable=False),
        sa.Column("not_before", sa.DateTime(), nullable=True),
        sa.Column("claim", sa.String(length=32), nullable=True),
        sa.Column("claimed_at", sa.DateTime(), nullable=True),
        sa.Column("depends_on_id", sa.Integer(), nullable=True),
        sa.Column("result", sa.JSON(), nullable=True),
        sa.Column("result_id", sa.String(length=64), nullable=False),
        sa.Column("note", sa.Text(), nullable=False),
        sa.Column("created_by", sa.String(length=200), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.Column("done_at", sa.DateTime(), nullable=True),
        sa.ForeignKeyConstraint(
            ["depends_on_id"],
            ["prolific_call.id"],
            name=op.f("fk_prolific_call_depends_on_id_prolific_call"),
        ),
        sa.ForeignKeyConstraint(
            ["study_id"],
            ["study.id"],
            name=op.f("fk_prolific_call_study_id_study"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_prolific_call")),
        sa.UniqueConstraint("key", name=op.f("uq_prolific_call_key")),
    )
    with op.batch_alter_table("prolific_call", schema=None) as batch_op:
        batch_op.create_index(
            "ix_prolific_call_study_id_state", ["study_id", "state"], unique=False
        )
    op.create_table(
        "prolific_study",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("study_id", sa.Integer(), nullable=False),
        sa.Column("pilot", sa.Boolean(), nullable=False),
        sa.Column("prolific_id", sa.String(length=64), nullable=True),
        sa.Column("test_study_id", sa.String(length=64), nullable=True),
        sa.Column("status", sa.String(length=30), nullable=False),
        sa.Column("status_at", sa.DateTime(), nullable=True),
        sa.Column("places", sa.Integer(), nullable=False),
        sa.Column("reward", sa.Integer(), nullable=False),
        sa.Column("currency", sa.String(length=3), nullable=False),
        sa.Column("workspace_id", sa.String(length=64), nullable=False),
        sa.Column("synced_at", sa.DateTime(), nullable=True),
        sa.ForeignKeyConstraint(
            ["study_id"],
            ["study.id"],
            name=op.f("fk_prolific_study_study_id_study"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_prolific_study")),
        sa.UniqueConstraint("prolific_id", name=op.f("uq_prolific_study_prolific_id")),
        sa.UniqueConstraint("study_id", "pilot", name=op.f("uq_prolific_study_study_id_pilot")),
        sa.UniqueConstraint("test_study_id", name=op.f("uq_prolific_study_test_study_id")),
    )
    op.create_table(
        "prolific_submission",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("study_id", sa.Integer(), nullable=False),
        sa.Column("submission_id", sa.String(length=64), nullable=False),
        sa.Column("prolific_pid", sa.String(length=64), nullable=False),
        sa.Column("status", sa.String(length=30), nullable=False),
        sa.Column("status_at", sa.DateTime(), nullable=True),
        sa.Column("started_at", sa.DateTime(), nullable=True),
        sa.Column("completed_at", sa.DateTime(), nullable=True),
        sa.Column("study_code", sa.String(length=80), nullable=True),
        sa.Column("pilot", sa.Boolean(), nullable=False),
        sa.ForeignKeyConstraint(
            ["study_id"],
            ["study.id"],
            name=op.f("fk_prolific_submission_study_id_study"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_prolific_submission")),
        sa.UniqueConstraint("submission_id", name=op.f("uq_prolific_submission_submission_id")),
    )
    with op.batch_alter_table("prolific_submission", schema=None) as batch_op:
        batch_op.create_index(
            batch_op.f("ix_prolific_submission_study_id"), ["study_id"], unique=False
        )


def downgrade():
    with op.batch_alter_table("prolific_submission", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_prolific_submission_study_id"))
    op.drop_table("prolific_submission")
    op.drop_table("prolific_study")
    with op.batch_alter_table("prolific_call", schema=None) as batch_op:
        batch_op.drop_index("ix_prolific_call_study_id_state")
    op.drop_table("prolific_call")
    op.drop_table("prolific_event")
