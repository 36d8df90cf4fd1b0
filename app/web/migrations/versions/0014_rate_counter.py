"""The consent limits' counters in the database, for deployments without Redis: one row per
limit window, raised in one statement by whichever web process takes the consent.

Revision ID: 0014_rate_counter
Revises: 0013_prolific
Create Date: 2026-12-07 06:30:00

"""

import sqlalchemy as sa
from alembic import op

revision = "0014_rate_counter"
down_revision = "0013_prolific"
branch_labels = None
depends_on = None


def upgrade():
    op.create_table(
        "rate_counter",
        sa.Column("key", sa.String(length=200), nullable=False),
        sa.Column("count", sa.Integer(), nullable=False),
        sa.Column("expires_at", sa.DateTime(), nullable=False),
        sa.PrimaryKeyConstraint("key", name=op.f("pk_rate_counter")),
    )
    with op.batch_alter_table("rate_counter", schema=None) as batch_op:
        batch_op.create_index(
            batch_op.f("ix_rate_counter_expires_at"), ["expires_at"], unique=False
        )


def downgrade():
    with op.batch_alter_table("rate_counter", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_rate_counter_expires_at"))
    op.drop_table("rate_counter")
