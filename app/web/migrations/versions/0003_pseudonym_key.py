"""Pseudonym key per study: the secret from which exports derive participants' pseudonymised
Prolific IDs (``app.privacy``), so an export shared for analysis names nobody.

Reviewed by hand: the column is added nullable, every existing study is given its own random
key, then the column becomes NOT NULL; batch mode keeps SQLite happy.

Revision ID: 0003_pseudonym_key
Revises: 0002_job_heartbeat
Create Date: 2026-11-24 09:00:00

"""

import secrets

import sqlalchemy as sa
from alembic import op

revision = "0003_pseudonym_key"
down_revision = "0002_job_heartbeat"
branch_labels = None
depends_on = None


def upgrade():
    with op.batch_alter_table("study", schema=None) as batch_op:
        batch_op.add_column(sa.Column("pseudonym_key", sa.String(length=64), nullable=True))
    study = sa.table(
        "study", sa.column("id", sa.Integer()), sa.column("pseudonym_key", sa.String(length=64))
    )
    connection = op.get_bind()
    for (study_id,) in connection.execute(sa.select(study.c.id)).all():
        connection.execute(
            sa.update(study)
            .where(study.c.id == study_id)
            .values(pseudonym_key=secrets.token_urlsafe(32))
        )
    with op.batch_alter_table("study", schema=None) as batch_op:
        batch_op.alter_column("pseudonym_key", existing_type=sa.String(length=64), nullable=False)


def downgrade():
    with op.batch_alter_table("study", schema=None) as batch_op:
        batch_op.drop_column("pseudonym_key")
