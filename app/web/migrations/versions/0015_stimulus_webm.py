"""A stimulus's WebM rendition (VP9 + Opus), for browsers that cannot play H.264: its path in
the study's media folder, or NULL where only the MP4 exists (clips rendered before this
revision keep playing from the MP4 alone; ``facepair study renditions`` makes theirs).

Reviewed by hand: one nullable column, no data to move; batch mode keeps SQLite happy.

Revision ID: 0015_stimulus_webm
Revises: 0014_rate_counter
Create Date: 2026-12-07 07:00:00

"""

import sqlalchemy as sa
from alembic import op

revision = "0015_stimulus_webm"
down_revision = "0014_rate_counter"
branch_labels = None
depends_on = None


def upgrade():
    with op.batch_alter_table("stimulus", schema=None) as batch_op:
        batch_op.add_column(sa.Column("webm_path", sa.String(length=500), nullable=True))


def downgrade():
    with op.batch_alter_table("stimulus", schema=None) as batch_op:
        batch_op.drop_column("webm_path")
