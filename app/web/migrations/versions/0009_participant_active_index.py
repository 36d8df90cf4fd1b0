"""A partial index over the participants taking part now (unfinished, not dropped), by study
and last request: the release of idle participants at every consent reads it instead of
scanning the study's whole participant table, so a consent costs the same in a study of 50
or 50,000.

Revision ID: 0009_participant_active_index
Revises: 0008_login_session
Create Date: 2026-12-03 13:20:00

"""

import sqlalchemy as sa
from alembic import op

revision = "0009_participant_active_index"
down_revision = "0008_login_session"
branch_labels = None
depends_on = None

ACTIVE = "finished_at IS NULL AND dropped_at IS NULL"


def upgrade():
    op.create_index(
        "ix_participant_active",
        "participant",
        ["study_id", "last_seen_at"],
        unique=False,
        postgresql_where=sa.text(ACTIVE),
        sqlite_where=sa.text(ACTIVE),
    )


def downgrade():
    op.drop_index("ix_participant_active", table_name="participant")
