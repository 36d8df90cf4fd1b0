"""Drop the vote's participant index: the unique (participant_id, trial_id) index leads with
the participant and serves every lookup by participant (the progress count, the next pair,
the foreign key's checks), so the single-column index only cost every vote one more index
entry.

Revision ID: 0007_vote_participant_index
Revises: 0006_vote_choice_check
Create Date: 2026-12-02 06:15:00

"""

from alembic import op

revision = "0007_vote_participant_index"
down_revision = "0006_vote_choice_check"
branch_labels = None
depends_on = None


def upgrade():
    with op.batch_alter_table("vote", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_vote_participant_id"))


def downgrade():
    with op.batch_alter_table("vote", schema=None) as batch_op:
        batch_op.create_index(
            batch_op.f("ix_vote_participant_id"), ["participant_id"], unique=False
        )
