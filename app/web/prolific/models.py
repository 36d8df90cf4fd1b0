"""The rows of recruiting on Prolific: the Prolific study of a facepair study, the outbox of
calls that change something at Prolific, the submissions as Prolific reports them, and the
webhook events received (kept for de-duplication by their event id).

No row holds the API token or the webhook secret: both come from the environment only
(``docs/reference/prolific.md``, "What is kept").
"""

from __future__ import annotations

import datetime as dt
from typing import Any

import sqlalchemy as sa
from sqlalchemy import orm as so

from app.web.extensions import db
from app.web.models import utcnow

#: The outbox's states. ``pending``: written, not yet sent (or waiting for ``not_before``);
#: ``sending``: claimed by one sender; ``done``: Prolific answered (or its state shows the
#: effect); ``failed``: Prolific refused it (the note says why); ``doubt``: it may have been
#: sent and Prolific's state cannot tell (a payment): a person decides
#: (``facepair prolific resolve``); ``cancelled``: withdrawn before it was sent.
CALL_STATES = ("pending", "sending", "done", "failed", "doubt", "cancelled")

# ``db.Model`` is built by Flask-SQLAlchemy at run time: mypy cannot see it as a base class.


class ProlificStudy(db.Model):  # type: ignore[name-defined]
    """The Prolific study made for a facepair study: the real one, or the pilot's draft."""

    #: Its index leads with the study: every lookup of a study's Prolific studies uses it.
    __table_args__ = (sa.UniqueConstraint("study_id", "pilot"),)
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id", ondelete="CASCADE"))
    #: The pilot's draft points at the pilot link; Prolific's test study is made from it.
    pilot: so.Mapped[bool] = so.mapped_column(default=False)
    #: Prolific's study id (None until the create call is done).
    prolific_id: so.Mapped[str | None] = so.mapped_column(sa.String(64), unique=True)
    #: The test study Prolific made from the pilot's draft (``POST .../test-study``).
    test_study_id: so.Mapped[str | None] = so.mapped_column(sa.String(64), unique=True)
    #: Prolific's status (UNPUBLISHED, ACTIVE, PAUSED, AWAITING REVIEW, COMPLETED, ...).
    status: so.Mapped[str] = so.mapped_column(sa.String(30), default="")
    #: When Prolific reported that status (a webhook's X-Timestamp, or the poll): older news
    #: never overwrites newer.
    status_at: so.Mapped[dt.datetime | None]
    places: so.Mapped[int] = so.mapped_column(default=0)
    #: Minor units of ``currency`` (Prolific's unit for rewards).
    reward: so.Mapped[int] = so.mapped_column(default=0)
    #: The workspace's currency, read from Prolific when the study was made.
    currency: so.Mapped[str] = so.mapped_column(sa.String(3), default="")
    workspace_id: so.Mapped[str] = so.mapped_column(sa.String(64), default="")
    synced_at: so.Mapped[dt.datetime | None]


class ProlificCall(db.Model):  # type: ignore[name-defined]
    """One change at Prolific, written before it is sent (the outbox): sent at most once."""

    #: A sender's question: this study's calls in this state.
    __table_args__ = (sa.Index("ix_prolific_call_study_id_state", "study_id", "state"),)
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id", ondelete="CASCADE"))
    #: What it does (``app.web.prolific.calls.KINDS``): create, publish, test_study, approve,
    #: reject, return, bonus, pay, top_up.
    kind: so.Mapped[str] = so.mapped_column(sa.String(20))
    #: The intent's idempotency key: the same intent (the same approval, the same bonus file)
    #: writes no second row.
    key: so.Mapped[str] = so.mapped_column(sa.String(200), unique=True)
    #: The Prolific id it acts on (a submission, a study, a bonus batch), once known.
    target: so.Mapped[str] = so.mapped_column(sa.String(64), default="")
    #: The request body as sent (never a secret).
    payload: so.Mapped[dict[str, Any]] = so.mapped_column(sa.JSON, default=dict)
    #: One of :data:`CALL_STATES`.
    state: so.Mapped[str] = so.mapped_column(sa.String(12), default="pending")
    attempts: so.Mapped[int] = so.mapped_column(default=0)
    #: Not to be tried before this time (back-off; a submission not yet awaiting review).
    not_before: so.Mapped[dt.datetime | None]
    #: The sender holding it (a random token) and since when: a claim older than the lease is
    #: a sender that died, and the call is reconciled with Prolific's state before any resend.
    claim: so.Mapped[str | None] = so.mapped_column(sa.String(32))
    claimed_at: so.Mapped[dt.datetime | None]
    #: A call that must be done first (publish after create, pay after its bonus batch).
    depends_on_id: so.Mapped[int | None] = so.mapped_column(sa.ForeignKey("prolific_call.id"))
    #: Prolific's answer (or the state read back from Prolific).
    result: so.Mapped[dict[str, Any] | None] = so.mapped_column(sa.JSON)
    #: The id Prolific gave (a study, a bonus batch).
    result_id: so.Mapped[str] = so.mapped_column(sa.String(64), default="")
    #: The last error, or why it waits or is in doubt.
    note: so.Mapped[str] = so.mapped_column(sa.Text, default="")
    #: Who asked for it (an experimenter's e-mail, or "cli").
    created_by: so.Mapped[str] = so.mapped_column(sa.String(200), default="")
    created_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    done_at: so.Mapped[dt.datetime | None]

    depends_on: so.Mapped[ProlificCall | None] = so.relationship(remote_side=[id])


class ProlificSubmission(db.Model):  # type: ignore[name-defined]
    """A submission as Prolific last reported it (polling or a webhook)."""

    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(
        sa.ForeignKey("study.id", ondelete="CASCADE"), index=True
    )
    #: Prolific's submission id: the SESSION_ID in the participant's link.
    submission_id: so.Mapped[str] = so.mapped_column(sa.String(64), unique=True)
    prolific_pid: so.Mapped[str] = so.mapped_column(sa.String(64), default="")
    status: so.Mapped[str] = so.mapped_column(sa.String(30), default="")
    #: When Prolific reported ``status``: older news never overwrites newer.
    status_at: so.Mapped[dt.datetime | None]
    started_at: so.Mapped[dt.datetime | None]
    completed_at: so.Mapped[dt.datetime | None]
    #: The completion code the participant used.
    study_code: so.Mapped[str | None] = so.mapped_column(sa.String(80))
    #: From the pilot's test study.
    pilot: so.Mapped[bool] = so.mapped_column(default=False)


class ProlificEvent(db.Model):  # type: ignore[name-defined]
    """A webhook delivery, kept by its X-Event-ID: a redelivery is acknowledged, not applied."""

    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    event_id: so.Mapped[str] = so.mapped_column(sa.String(100), unique=True)
    event_type: so.Mapped[str] = so.mapped_column(sa.String(60), default="")
    resource_id: so.Mapped[str] = so.mapped_column(sa.String(64), default="")
    status: so.Mapped[str] = so.mapped_column(sa.String(30), default="")
    #: X-Timestamp: when Prolific sent it (events are ordered by it).
    sent_at: so.Mapped[dt.datetime | None]
    received_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    #: What came of it: applied, older than what is known, no such submission, ...
    outcome: so.Mapped[str] = so.mapped_column(sa.String(200), default="")
