"""Job heartbeat: when the process running a job last reported, so the sweeper can tell a job
whose process died (a killed render, a restarted worker) from one still working.

Reviewed by hand: one nullable column, no data to move; batch mode keeps SQLite happy.

Revision ID: 0002_job_heartbeat
Revises: 0001
Create Date: 2026-11-23 10:00:00

"""

from alembic import op
import sqlalchemy as sa


revision = "0002_job_heartbeat"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade():
    with op.batch_alter_table("job", schema=None) as batch_op:
        batch_op.add_column(sa.Column("heartbeat_at", sa.DateTime(), nullable=True))


def downgrade():
    with op.batch_alter_table("job", schema=None) as batch_op:
        batch_op.drop_column("heartbeat_at")
