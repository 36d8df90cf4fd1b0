"""How a participant was taken out (excluded by the experimenter, or returned on Prolific) in a
column of its own, so the reason typed for a returned submission is kept and an exclusion can
be undone.

Reviewed by hand: existing rows get the kind their stored reason implied (the fixed text
"returned the submission on Prolific" meant returned, any other reason of an excluded row
meant excluded); batch mode keeps SQLite happy.

Revision ID: 0011_experimenter_records
Revises: 0010_participant_language_audio
Create Date: 2026-12-05 23:00:00

"""

import sqlalchemy as sa
from alembic import op

revision = "0011_experimenter_records"
down_revision = "0010_participant_language_audio"
branch_labels = None
depends_on = None

#: The reason stored for a returned submission before this revision.
RETURNED = "returned the submission on Prolific"


def upgrade():
    with op.batch_alter_table("participant", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("exclusion_kind", sa.String(length=10), server_default="", nullable=False)
        )
    participant = sa.table(
        "participant",
        sa.column("excluded_at", sa.DateTime()),
        sa.column("exclusion_reason", sa.String(length=300)),
        sa.column("exclusion_kind", sa.String(length=10)),
    )
    connection = op.get_bind()
    taken_out = participant.c.excluded_at.is_not(None)
    connection.execute(
        sa.update(participant)
        .where(taken_out, participant.c.exclusion_reason == RETURNED)
        .values(exclusion_kind="returned", exclusion_reason="")
    )
    connection.execute(
        sa.update(participant)
        .where(taken_out, participant.c.exclusion_kind == "")
        .values(exclusion_kind="excluded")
    )


def downgrade():
    participant = sa.table(
        "participant",
        sa.column("exclusion_reason", sa.String(length=300)),
        sa.column("exclusion_kind", sa.String(length=10)),
    )
    op.get_bind().execute(
        sa.update(participant)
        .where(participant.c.exclusion_kind == "returned")
        .values(exclusion_reason=RETURNED)
    )
    with op.batch_alter_table("participant", schema=None) as batch_op:
        batch_op.drop_column("exclusion_kind")
