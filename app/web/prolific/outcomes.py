"""The submissions' outcomes as Prolific reports them: its webhook (``submission.status.change``
and ``study.status.change``) and polling (:func:`sync`, for deployments without a public URL).

Webhook deliveries are checked as Prolific documents it (API reference, Webhooks, "Verifying"):
``X-Prolific-Request-Signature`` is the base64 HMAC-SHA256, keyed with the workspace's secret,
of ``X-Prolific-Request-Timestamp`` followed by the body. Events are delivered at least once
("Idempotency and the X-Event-ID header"): each ``X-Event-ID`` is applied once, a redelivery is
acknowledged. Their order is not guaranteed ("Handling event order with X-Timestamp"): a status
is applied only if it is newer (by ``X-Timestamp``) than the one known, and a poll counts as
news of its own moment.

A submission RETURNED or TIMED-OUT makes its participant ``returned``
(``app.web.study.participants.remove``): their list slot goes back, the report leaves them out.
"""

from __future__ import annotations

import base64
import datetime as dt
import hashlib
import hmac
import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import sqlalchemy as sa
from sqlalchemy.exc import IntegrityError

from app.web.extensions import db
from app.web.models import Participant, Study, utcnow
from app.web.prolific.calls import study_submissions
from app.web.prolific.client import ProlificClient
from app.web.prolific.models import ProlificEvent, ProlificStudy, ProlificSubmission
from app.web.study.participants import remove

RETURNING = ("RETURNED", "TIMED-OUT")
SIGNATURE = "X-Prolific-Request-Signature"
SIGNED_AT = "X-Prolific-Request-Timestamp"
EVENT_ID = "X-Event-ID"
SENT_AT = "X-Timestamp"
EVENT_TYPES = ("submission.status.change", "study.status.change")
#: A signature older (or further in the future) than this is refused (seconds).
MAX_AGE_SECONDS = 3600
#: Clock difference allowed to an event's X-Timestamp ahead of this server.
FUTURE_SKEW_SECONDS = 300


def _unix(value: Any) -> dt.datetime | None:
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        return None
    if not (0 < seconds < 1e11):
        return None
    return dt.datetime.fromtimestamp(seconds, dt.UTC).replace(tzinfo=None)


def _iso(value: Any) -> dt.datetime | None:
    if not isinstance(value, str) or not value:
        return None
    try:
        moment = dt.datetime.fromisoformat(value.replace("Z", "+00:00"))
    except ValueError:
        return None
    return moment.astimezone(dt.UTC).replace(tzinfo=None) if moment.tzinfo else moment


def participant_for(study_id: int, submission_id: str, prolific_pid: str) -> Participant | None:
    """The facepair participant of a submission: by its SESSION_ID, else by PROLIFIC_PID."""
    found = db.session.scalar(
        sa.select(Participant).where(
            Participant.study_id == study_id, Participant.prolific_session_id == submission_id
        )
    )
    if found is None and prolific_pid:
        found = db.session.scalar(
            sa.select(Participant).where(
                Participant.study_id == study_id, Participant.prolific_pid == prolific_pid
            )
        )
    return found


def note_submission(
    study_id: int,
    submission_id: str,
    *,
    status: str,
    at: dt.datetime,
    prolific_pid: str = "",
    pilot: bool = False,
    details: Mapping[str, Any] | None = None,
) -> str:
    """Keep what Prolific says of a submission if it is newer than what is known, and make a
    returned or timed-out one's participant ``returned``. Not committed; returns what came of
    it."""
    row = db.session.scalar(
        sa.select(ProlificSubmission).where(ProlificSubmission.submission_id == submission_id)
    )
    if row is None:
        row = ProlificSubmission(study_id=study_id, submission_id=submission_id, pilot=pilot)
        db.session.add(row)
    elif row.status_at is not None and at < row.status_at:
        return f"older than the {row.status} known"
    row.status, row.status_at = status[:30], at
    if prolific_pid:
        row.prolific_pid = prolific_pid[:64]
    details = details or {}
    row.started_at = _iso(details.get("started_at")) or row.started_at
    row.completed_at = _iso(details.get("completed_at")) or row.completed_at
    code = details.get("study_code")
    if isinstance(code, str):
        row.study_code = code[:80]
    db.session.flush()
    if status in RETURNING:
        person = participant_for(row.study_id, submission_id, row.prolific_pid)
        if person is not None and person.excluded_at is None and not person.pilot:
            remove(person, how="returned", reason=f"Prolific: submission {status}")
            return f"applied: {status}, participant P{person.number:04d} returned"
    return f"applied: {status}"


@dataclass
class SyncReport:
    submissions: int = 0
    returned: int = 0
    studies: int = 0


def sync(study: Study, client: ProlificClient) -> SyncReport:
    """Poll Prolific for ``study``'s Prolific studies and their submissions (the fallback for
    deployments without a public webhook URL). Committed."""
    report = SyncReport()
    links = db.session.scalars(
        sa.select(ProlificStudy).where(
            ProlificStudy.study_id == study.id, ProlificStudy.prolific_id.is_not(None)
        )
    ).all()
    for link in links:
        now = utcnow()  # the news is as of the request
        data = client.get(f"/api/v1/studies/{link.prolific_id}/", call="read the study")
        if isinstance(data, dict):
            if link.status_at is None or now >= link.status_at:
                link.status, link.status_at = str(data.get("status", link.status))[:30], now
            places = data.get("total_available_places")
            if isinstance(places, int | float):
                link.places = int(places)
        report.studies += 1
        for prolific_id, pilot in ((link.prolific_id, link.pilot), (link.test_study_id, True)):
            if not prolific_id:
                continue
            now = utcnow()
            for item in study_submissions(client, prolific_id):
                outcome = note_submission(
                    study.id,
                    str(item.get("id", ""))[:64],
                    status=str(item.get("status", "")),
                    at=now,
                    prolific_pid=str(item.get("participant_id", "")),
                    pilot=pilot,
                    details=item,
                )
                report.submissions += 1
                report.returned += "returned" in outcome
        link.synced_at = utcnow()
    db.session.commit()
    return report


class Refused(Exception):
    """A webhook delivery refused: its HTTP status and one line."""

    def __init__(self, status: int, message: str) -> None:
        self.status, self.message = status, message
        super().__init__(message)


def signature(secret: str, timestamp: str, body: bytes) -> str:
    """Prolific's webhook signature: base64(HMAC-SHA256(secret, timestamp + body))."""
    digest = hmac.new(secret.encode(), timestamp.encode() + body, hashlib.sha256).digest()
    return base64.b64encode(digest).decode()


def verify(
    secret: str, headers: Mapping[str, str], body: bytes, *, now: dt.datetime, max_age: float
) -> None:
    """Raise :class:`Refused` (401) unless the delivery is signed with ``secret`` and the
    signature is fresh. The body is checked as received and, as Prolific's own example does,
    as ``json.dumps`` of the parsed body."""
    given = headers.get(SIGNATURE, "")
    stamp = headers.get(SIGNED_AT, "")
    signed_at = _unix(stamp)
    if not given or signed_at is None:
        raise Refused(401, f"unsigned: {SIGNATURE} and {SIGNED_AT} are required")
    forms = [body]
    try:
        forms.append(json.dumps(json.loads(body)).encode())
    except (ValueError, RecursionError):
        pass
    # as bytes: compare_digest refuses text with non-ASCII characters, which a header may hold
    given_bytes = given.encode("utf-8", "replace")
    expected = (signature(secret, stamp, form).encode() for form in forms)
    if not any(hmac.compare_digest(digest, given_bytes) for digest in expected):
        raise Refused(401, "bad signature")
    if abs((now - signed_at).total_seconds()) > max_age:
        raise Refused(401, "the signature is too old")


def receive(
    headers: Mapping[str, str],
    body: bytes,
    *,
    secret: str,
    now: dt.datetime | None = None,
    max_age: float = MAX_AGE_SECONDS,
) -> tuple[int, dict[str, str]]:
    """Handle one webhook delivery; returns (HTTP status, JSON answer). Committed. Never
    raises on what the sender controls."""
    now = now or utcnow()
    try:
        verify(secret, headers, body, now=now, max_age=max_age)
        event = _event(headers, body)
    except Refused as exc:
        return exc.status, {"error": exc.message}
    event_id, event_type, resource_id, status, pid = event
    sent_at = _unix(headers.get(SENT_AT)) or _unix(headers.get(SIGNED_AT)) or now
    # X-Timestamp is not signed: a time in the future would hold back every later status
    sent_at = min(sent_at, now + dt.timedelta(seconds=FUTURE_SKEW_SECONDS))
    row = ProlificEvent(
        event_id=event_id,
        event_type=event_type[:60],
        resource_id=resource_id,
        status=status[:30],
        sent_at=sent_at,
    )
    db.session.add(row)
    try:
        db.session.flush()
        row.outcome = _apply(event_type, resource_id, status, sent_at, pid)[:200]
        db.session.commit()
    except IntegrityError:
        db.session.rollback()
        return 200, {"status": "duplicate", "event": event_id}
    return 200, {"status": row.outcome, "event": event_id}


def _event(headers: Mapping[str, str], body: bytes) -> tuple[str, str, str, str, str]:
    event_id = headers.get(EVENT_ID, "").strip()
    if not event_id or len(event_id) > 100 or not event_id.isprintable():
        raise Refused(400, f"{EVENT_ID}: expected an event id of at most 100 characters")
    try:
        data = json.loads(body)
    except (ValueError, RecursionError):
        raise Refused(400, "body: expected a JSON object") from None
    if not isinstance(data, dict):
        raise Refused(400, "body: expected a JSON object")
    fields = {}
    for key in ("event_type", "resource_id"):
        value = data.get(key)
        if not isinstance(value, str) or not value or len(value) > 64:
            raise Refused(400, f"{key}: expected a string of at most 64 characters")
        fields[key] = value
    status = data.get("status", "")
    pid = data.get("participant_id", "")
    if not isinstance(status, str) or not isinstance(pid, str) or len(pid) > 64:
        raise Refused(400, "status and participant_id: expected strings")
    if not all(text.isprintable() for text in (*fields.values(), status, pid)):
        raise Refused(400, "body: control characters in a field")
    return event_id, fields["event_type"], fields["resource_id"], status, pid


def _apply(event_type: str, resource_id: str, status: str, sent_at: dt.datetime, pid: str) -> str:
    if event_type == "submission.status.change":
        if not status:
            return "no status"
        known = db.session.scalar(
            sa.select(ProlificSubmission).where(ProlificSubmission.submission_id == resource_id)
        )
        study_id = known.study_id if known is not None else None
        if study_id is None:
            person = db.session.scalar(
                sa.select(Participant)
                .where(Participant.prolific_session_id == resource_id)
                .limit(1)
            )
            study_id = person.study_id if person is not None else None
        if study_id is None:
            return "no such submission here (yet): the next poll finds it"
        return note_submission(study_id, resource_id, status=status, at=sent_at, prolific_pid=pid)
    if event_type == "study.status.change":
        link = db.session.scalar(
            sa.select(ProlificStudy).where(
                sa.or_(
                    ProlificStudy.prolific_id == resource_id,
                    ProlificStudy.test_study_id == resource_id,
                )
            )
        )
        if link is None:
            return "no such study here"
        if link.status_at is not None and sent_at < link.status_at:
            return f"older than the {link.status} known"
        if status:
            link.status, link.status_at = status[:30], sent_at
        return f"applied: study {status}"
    return f"ignored: {event_type}"
