"""The outbox: every call that changes something at Prolific is first a row, then sent, then
marked done with Prolific's answer, so that a crash, a retry, a second command or a second
worker never sends it twice (``docs/reference/prolific.md``, "Never twice").

1. :func:`record` writes the intent under its idempotency key and commits: the same intent
   (the same approval, the same bonus file) finds its row instead of writing a second.
2. A sender claims a due row with one conditional UPDATE (``pending -> sending`` with its own
   claim token) in its own transaction: of two senders, one gets the row.
3. It sends the call (``app.web.prolific.calls``) and marks the row done, failed, waiting or in
   doubt, only while it still holds the claim.
4. A row left ``sending`` by a sender that died (its claim older than
   ``PROLIFIC_CLAIM_LEASE_SECONDS``) is taken over and reconciled: Prolific's state is read
   first (is the submission approved, the study created, the bonus paid?), and the call is sent
   again only when that state shows it was not done and sending again is safe. Prolific's API
   takes no idempotency keys (none in its OpenAPI document), so reading back is the only check.
   A payment whose effect is not visible yet is never sent again by itself: the row goes to
   ``doubt`` and a person decides (:func:`resolve`).

:func:`checkpoint` marks the places a crash is injected in the tests.
"""

from __future__ import annotations

import datetime as dt
import secrets
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import sqlalchemy as sa
from flask import current_app
from sqlalchemy.exc import IntegrityError

from app.errors import InputError
from app.web.extensions import db
from app.web.models import utcnow
from app.web.prolific import calls
from app.web.prolific.client import InDoubt, ProlificClient, ProlificError, Unreachable, setting
from app.web.prolific.models import ProlificCall

#: A claim older than this (seconds) belongs to a sender that died: longer than one call with
#: all its retries can take.
LEASE_SECONDS = 600
#: Back-off of a call that could not be sent (Prolific away, a 429 storm): seconds, doubled
#: per attempt, at most MAX_DELAY.
DELAY_SECONDS = 30
MAX_DELAY = 1800


def checkpoint(point: str, call: ProlificCall) -> None:
    """Where a crash may strike: after ``written`` (the row committed), ``claimed`` (the claim
    committed, nothing sent), ``prepared`` (a payment's baseline read and kept), ``sent``
    (Prolific answered, nothing marked). Does nothing; the tests replace it."""


@dataclass(frozen=True)
class Intent:
    """A call to be made: its kind (:data:`app.web.prolific.calls.KINDS`), its idempotency
    key, the body and the Prolific id it acts on (or the call whose answer gives it)."""

    kind: str
    key: str
    payload: dict[str, Any] = field(default_factory=dict)
    target: str = ""
    depends_on: ProlificCall | None = None


def lease() -> dt.timedelta:
    return dt.timedelta(
        seconds=setting(current_app.config, "PROLIFIC_CLAIM_LEASE_SECONDS", LEASE_SECONDS)
    )


def _first_delay() -> float:
    return setting(current_app.config, "PROLIFIC_RETRY_DELAY_SECONDS", DELAY_SECONDS)


def record(
    study_id: int, intents: Iterable[Intent], *, created_by: str
) -> list[tuple[ProlificCall, bool]]:
    """Write each intent not yet written (by its key) and commit; returns ``(row, new)`` per
    intent, in order. Committed here: a row exists before anything is sent."""
    intents = list(intents)
    for kind in {i.kind for i in intents}:
        if kind not in calls.KINDS:
            raise ValueError(f"unknown call kind {kind!r}")
    for _ in range(2):
        out: list[tuple[ProlificCall, bool]] = []
        try:
            for intent in intents:
                found = db.session.scalar(
                    sa.select(ProlificCall).where(ProlificCall.key == intent.key)
                )
                if found is not None:
                    out.append((found, False))
                    continue
                row = ProlificCall(
                    study_id=study_id,
                    kind=intent.kind,
                    key=intent.key,
                    payload=intent.payload,
                    target=intent.target,
                    depends_on_id=intent.depends_on.id if intent.depends_on else None,
                    created_by=created_by[:200],
                )
                db.session.add(row)
                db.session.flush()
                out.append((row, True))
            db.session.commit()
        except IntegrityError:
            # another sender wrote the same intent at the same moment: read theirs
            db.session.rollback()
            continue
        for row, new in out:
            if new:
                checkpoint("written", row)
        return out
    raise InputError("the outbox is busy: try again", field="outbox")


def _rowcount(result: Any) -> int:
    """The rows an UPDATE matched (a ``CursorResult``'s count, typed loosely by SQLAlchemy)."""
    return int(getattr(result, "rowcount", 0) or 0)


def _claim(
    row_id: int, *, stale_before: dt.datetime | None = None, old_claim: str | None = None
) -> str | None:
    """Take row ``row_id`` for this sender (a pending row, or a ``sending`` row whose claim is
    older than ``stale_before``); returns the claim token, or None if another sender has it."""
    token = secrets.token_hex(8)
    now = utcnow()
    query = sa.update(ProlificCall).where(ProlificCall.id == row_id)
    if stale_before is None:
        query = query.where(ProlificCall.state == "pending").values(
            attempts=ProlificCall.attempts + 1
        )
    else:
        query = query.where(
            ProlificCall.state == "sending",
            ProlificCall.claim == old_claim,
            ProlificCall.claimed_at < stale_before,
        )
    result = db.session.execute(
        query.values(state="sending", claim=token, claimed_at=now).execution_options(
            synchronize_session=False
        )
    )
    db.session.commit()
    return token if _rowcount(result) == 1 else None


def _finish(row: ProlificCall, token: str, outcome: calls.Outcome) -> bool:
    """Write ``outcome`` on ``row`` if this sender still holds it; True if written."""
    values: dict[str, Any] = {"note": outcome.note[:2000], "claim": None}
    if outcome.target:
        values["target"] = outcome.target
    if outcome.result is not None:
        values["result"] = outcome.result
    if isinstance(outcome, calls.Done):
        values |= {
            "state": "done",
            "done_at": utcnow(),
            "result_id": outcome.result_id or row.result_id,
        }
    elif isinstance(outcome, calls.Wait):
        delay = (
            outcome.delay
            if outcome.delay is not None
            else min(MAX_DELAY, _first_delay() * 2 ** max(0, row.attempts - 1))
        )
        values |= {"state": "pending", "not_before": utcnow() + dt.timedelta(seconds=delay)}
    elif isinstance(outcome, calls.Failed):
        values |= {"state": "failed"}
    else:
        values |= {"state": "doubt"}
    result = db.session.execute(
        sa.update(ProlificCall)
        .where(ProlificCall.id == row.id, ProlificCall.claim == token)
        .values(**values)
        .execution_options(synchronize_session=False)
    )
    written = _rowcount(result) == 1
    if written and isinstance(outcome, calls.Done):
        calls.after_done(row.kind, db.session.get(ProlificCall, row.id), outcome)
    db.session.commit()
    db.session.expire_all()
    return written


def _outcome_of_error(row: ProlificCall, exc: ProlificError) -> calls.Outcome:
    if isinstance(exc, Unreachable) or exc.status is None or exc.status == 429:
        return calls.Wait(f"not sent: {exc}")
    if exc.status >= 500:
        return calls.Wait(f"Prolific failed: {exc}")
    return calls.Failed(str(exc))


def _send(row: ProlificCall, token: str, client: ProlificClient) -> None:
    """Send one claimed row and write what came of it."""
    dependency = db.session.get(ProlificCall, row.depends_on_id) if row.depends_on_id else None
    try:
        checkpoint("claimed", row)
        outcome = calls.send(client, row, dependency, prepared=lambda: checkpoint("prepared", row))
    except InDoubt as exc:
        # Read back what happened; "not done" (None) makes it safe to send again later.
        try:
            observed = calls.observe(client, row)
        except ProlificError as again:
            observed = calls.Doubt(f"{exc}; reading it back: {again}")
        outcome = observed if observed is not None else calls.Wait(f"not done at Prolific: {exc}")
    except ProlificError as exc:
        outcome = _outcome_of_error(row, exc)
    checkpoint("sent", row)
    _finish(row, token, outcome)


def _reconcile(row: ProlificCall, client: ProlificClient) -> None:
    """A row a dead sender left ``sending``: read Prolific's state, then resend only if that is
    safe (``calls.observe``)."""
    token = _claim(row.id, stale_before=utcnow() - lease(), old_claim=row.claim)
    if token is None:
        return
    try:
        observed = calls.observe(client, row)
    except ProlificError as exc:
        db.session.execute(
            sa.update(ProlificCall)
            .where(ProlificCall.id == row.id, ProlificCall.claim == token)
            .values(note=f"reconciling: {exc}"[:2000])
        )
        db.session.commit()
        return
    if observed is not None:
        _finish(row, token, observed)
    elif row.kind == "approve":
        # approvals go in bulk: back in the queue, with the others
        _finish(row, token, calls.Wait("reconciled: not approved yet", delay=0))
    else:
        _send(row, token, client)


def _due(study_id: int) -> list[ProlificCall]:
    now = utcnow()
    done = sa.select(ProlificCall.id).where(ProlificCall.state == "done")
    return list(
        db.session.scalars(
            sa.select(ProlificCall)
            .where(
                ProlificCall.study_id == study_id,
                ProlificCall.state == "pending",
                sa.or_(ProlificCall.not_before.is_(None), ProlificCall.not_before <= now),
                sa.or_(ProlificCall.depends_on_id.is_(None), ProlificCall.depends_on_id.in_(done)),
            )
            .order_by(ProlificCall.id)
        )
    )


@dataclass
class DrainReport:
    sent: int = 0
    left: int = 0
    reconciled: int = 0


def drain(study_id: int, client: ProlificClient, *, rounds: int = 20) -> DrainReport:
    """Send every due call of study ``study_id`` (reconciling stale claims first), in the
    order they were written; approvals go in bulk. Returns how many were handled and how many
    are left (waiting, or held by another sender)."""
    report = DrainReport()
    stale = db.session.scalars(
        sa.select(ProlificCall).where(
            ProlificCall.study_id == study_id,
            ProlificCall.state == "sending",
            ProlificCall.claimed_at < utcnow() - lease(),
        )
    ).all()
    for row in stale:
        _reconcile(row, client)
        report.reconciled += 1
    recheck_doubts(study_id, client)
    for _ in range(rounds):
        due = _due(study_id)
        if not due:
            break
        approvals = [r for r in due if r.kind == "approve"]
        if approvals:
            report.sent += _send_approvals(approvals, client)
        for row in (r for r in due if r.kind != "approve"):
            token = _claim(row.id)
            if token is None:
                continue
            _send(db.session.get(ProlificCall, row.id), token, client)  # type: ignore[arg-type]
            report.sent += 1
    report.left = (
        db.session.scalar(
            sa.select(sa.func.count(ProlificCall.id)).where(
                ProlificCall.study_id == study_id, ProlificCall.state.in_(("pending", "sending"))
            )
        )
        or 0
    )
    return report


def _send_approvals(rows: list[ProlificCall], client: ProlificClient) -> int:
    """Claim the due approvals and send those Prolific has awaiting review in one bulk call;
    the others wait (not yet submitted) or fail (returned, rejected, timed out)."""
    held: list[tuple[ProlificCall, str]] = []
    for row in rows:
        token = _claim(row.id)
        if token is not None:
            held.append((db.session.get(ProlificCall, row.id), token))  # type: ignore[arg-type]
    if not held:
        return 0
    for row, _ in held:
        checkpoint("claimed", row)
    try:
        outcomes = calls.approve_in_bulk(client, [row for row, _ in held])
    except ProlificError as exc:
        outcomes = {row.id: _outcome_of_error(row, exc) for row, _ in held}
    for row, _ in held:
        checkpoint("sent", row)
    for row, token in held:
        _finish(row, token, outcomes[row.id])
    return len(held)


def recheck_doubts(study_id: int, client: ProlificClient) -> int:
    """Read Prolific's state again for calls in doubt: a payment that has since shown up is
    done. Returns how many were settled."""
    settled = 0
    for row in db.session.scalars(
        sa.select(ProlificCall).where(
            ProlificCall.study_id == study_id, ProlificCall.state == "doubt"
        )
    ).all():
        try:
            observed = calls.observe(client, row)
        except ProlificError:
            continue
        if isinstance(observed, calls.Done):
            db.session.execute(
                sa.update(ProlificCall)
                .where(ProlificCall.id == row.id, ProlificCall.state == "doubt")
                .values(
                    state="done",
                    done_at=utcnow(),
                    note=observed.note[:2000],
                    result=observed.result or row.result,
                )
            )
            db.session.commit()
            calls.after_done(row.kind, db.session.get(ProlificCall, row.id), observed)
            db.session.commit()
            settled += 1
    return settled


#: What a person may say of a call: it was sent (done), it was not (send it), or drop it.
RESOLUTIONS = ("sent", "not-sent", "cancel")


def resolve(row: ProlificCall, how: str, *, who: str) -> str:
    """A person's decision on a call: ``sent`` or ``not-sent`` for a call in doubt (after
    looking at Prolific's page), ``cancel`` for one not yet done. Returns the new state.
    Committed."""
    if how not in RESOLUTIONS:
        raise InputError(
            f"expected one of {', '.join(RESOLUTIONS)}, got {how!r}", field="resolution"
        )
    if how in ("sent", "not-sent") and row.state != "doubt":
        raise InputError(f"call {row.id} is {row.state}, not in doubt", field="CALL_ID")
    if how == "cancel" and row.state not in ("pending", "failed", "doubt"):
        raise InputError(
            f"call {row.id} is {row.state}: only a pending, failed or doubtful call is cancelled",
            field="CALL_ID",
        )
    state = {"sent": "done", "not-sent": "pending", "cancel": "cancelled"}[how]
    values: dict[str, Any] = {
        "state": state,
        "note": f"{how} (decided by {who})",
        "claim": None,
        "not_before": None,
    }
    if how == "cancel":
        # the intent may be written again: the cancelled row keeps a key of its own
        values["key"] = f"{row.key}:cancelled:{row.id}"[:200]
    if state == "done":
        values["done_at"] = utcnow()
    if how == "not-sent":
        # the baseline of a payment is read again before it is sent again
        values["result"] = None
    db.session.execute(
        sa.update(ProlificCall)
        .where(ProlificCall.id == row.id, ProlificCall.state == row.state)
        .values(**values)
    )
    db.session.commit()
    return state


def calls_of(study_id: int) -> list[ProlificCall]:
    """The study's outbox, oldest first."""
    return list(
        db.session.scalars(
            sa.select(ProlificCall)
            .where(ProlificCall.study_id == study_id)
            .order_by(ProlificCall.id)
        )
    )
