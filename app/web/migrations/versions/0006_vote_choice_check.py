"""A vote's choice is one of left, right, undecided, in the database too.

Reviewed by hand: every stored vote went through the web layer's choice check, so no row breaks
the constraint. The choices are written out rather than imported: a migration records the
schema as it was when written. Batch mode keeps SQLite happy (the table is copied).

Revision ID: 0006_vote_choice_check
Revises: 0005_experimenter_side
Create Date: 2026-12-01 03:30:00

"""

import sqlalchemy as sa
from alembic import op

revision = "0006_vote_choice_check"
down_revision = "0005_experimenter_side"
branch_labels = None
depends_on = None


def upgrade():
    with op.batch_alter_table("vote", schema=None) as batch_op:
        batch_op.create_check_constraint(
            batch_op.f("ck_vote_choice"), sa.column("choice").in_(["left", "right", "undecided"])
        )


def downgrade():
    with op.batch_alter_table("vote", schema=None) as batch_op:
        batch_op.drop_constraint(batch_op.f("ck_vote_choice"), type_="check")
