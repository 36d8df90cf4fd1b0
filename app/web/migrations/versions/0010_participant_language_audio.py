"""The audio check's state and result per participant (answers by attempt, passed or not);
the study's language and audio-check settings live in ``study.settings`` (JSON), so only the
participant gains a column.

Revision ID: 0010_participant_language_audio
Revises: 0009_participant_active_index
Create Date: 2026-12-05 23:30:00

"""

import sqlalchemy as sa
from alembic import op

revision = "0010_participant_language_audio"
down_revision = "0009_participant_active_index"
branch_labels = None
depends_on = None


def upgrade():
    with op.batch_alter_table("participant", schema=None) as batch_op:
        batch_op.add_column(sa.Column("audio_check", sa.JSON(), nullable=True))


def downgrade():
    with op.batch_alter_table("participant", schema=None) as batch_op:
        batch_op.drop_column("audio_check")
