"""Recording a vote exactly once.

A vote is written when it is cast, by one path (:func:`record_vote`) on every database.
Retried and double-clicked submissions carry the same idempotency key and are answered with the
stored vote; the unique constraints on ``vote.idempotency_key`` and ``vote(participant_id,
trial_id)`` settle races between concurrent requests (the loser's INSERT does nothing and it
reads the winner's row), and the participant's row, locked for the request, stores one
participant's votes one after the other.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from functools import cache
from types import EllipsisType
from typing import Any, NamedTuple

import sqlalchemy as sa
from sqlalchemy import orm as so
from sqlalchemy.dialects import postgresql, sqlite

from app.trials import rules
from app.trials.design import RATING_DESIGNS
from app.trials.rating import catch_ceiling
from app.web.extensions import db
from app.web.infra import limits
from app.web.models import Participant, Rating, Study, Trial, Vote, utcnow
from app.web.study.adaptive import ADAPTIVE, choose_next_pair
from app.web.study.audiocheck import pending as audio_check_pending
from app.web.study.enrolment import SESSION_ENDED, touch
from app.web.study.medialog import MediaLogError, media_fields
from app.web.study.participants import release_if_left_out
from app.web.study.progress import next_trial_of, progress_and_upcoming, rated
from app.web.study.studies import participation, rating_scale

#: What a participant reads when the attention stop rule has ended their session.
SCREENED_OUT = (
    "your session has ended because several attention checks were missed; thank you for your time"
)


class AnswerRejected(Exception):
    """The request cannot be an answer (a vote or a rating) of this participant; ``status`` is
    the HTTP status. Raised as such by the checks every answer passes (the study open, the
    participant answering, the fields both carry); :class:`VoteRejected` and
    :class:`app.web.study.ratings.RatingRejected` for what only a vote or a rating is checked
    for."""

    def __init__(self, message: str, status: int = 400, *, closed: bool = False) -> None:
        super().__init__(message)
        self.message = message
        self.status = status
        #: Refused for good: the study takes no more answers (the browser stops resending).
        self.closed = closed


class VoteRejected(AnswerRejected):
    """The request cannot be a vote of this participant."""


class StoredVote(NamedTuple):
    """What the answer to a vote repeats of the vote stored for its trial."""

    trial_id: int
    choice: str
    plays: int
    response_ms: int | None
    strength: int | None


@dataclass(frozen=True)
class VoteOutcome:
    vote: StoredVote
    #: True when this request stored it; False when it was already stored (a retry).
    created: bool
    answered: int
    total: int
    #: The next pair as the trial page shows it (:func:`app.web.study.progress.upcoming`'s row),
    #: read in the vote's transaction; None when the schedule is done or the session has ended
    #: (the browser then loads the trial page, which decides).
    upcoming: Any = None


def replay_policy(study: Study) -> rules.ReplayPolicy:
    """The study's replay policy (:class:`app.trials.rules.ReplayPolicy`)."""
    return rules.ReplayPolicy(
        study.replay, max_plays=study.max_plays if study.replay == "max_plays" else None
    )


def may_vote(study: Study, *, plays: int, watched_to_end: bool) -> str | None:
    """Why a vote after ``plays`` plays is refused by the study's replay policy, or None
    (:func:`app.trials.rules.vote_refusal`)."""
    return rules.vote_refusal(replay_policy(study), plays, watched_to_end)


def parse_time(value: Any) -> dt.datetime | None:
    if value is None or value == "":
        return None
    try:
        if not isinstance(value, str) or len(value) > 40:
            raise ValueError(value)
        stamp = dt.datetime.fromisoformat(value.replace("Z", "+00:00"))
        if stamp.tzinfo is not None:
            stamp = stamp.astimezone(dt.UTC).replace(tzinfo=None)
    except (ValueError, OverflowError) as exc:  # overflow: a time zone beyond year 1 or 9999
        raise AnswerRejected("presented_at: expected an ISO 8601 time") from exc
    return stamp


def int_field(
    payload: dict[str, Any], name: str, column: Any, *, required: bool = False
) -> int | None:
    """A non-negative whole number that fits ``column`` (JSON may spell it 3.0)."""
    value = payload.get(name)
    if value is None:
        if required:
            raise AnswerRejected(f"{name}: required")
        return None
    if isinstance(value, float) and value.is_integer():  # never NaN or infinity
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise AnswerRejected(f"{name}: expected a non-negative whole number")
    found = limits.problem(limits.column_of(column), value)
    if found:
        raise AnswerRejected(f"{name}: {found}")
    return value


def check_open(study: Any, *, pilot: bool) -> None:
    """Refuse a vote on a study that takes no answers (pilots vote before it opens)."""
    # Pilot participants (``app.web.study.participants``) vote before recruitment opens.
    piloting = pilot and study.status in ("draft", "ready")
    if study.status not in ("open", "paused") and not piloting:
        raise AnswerRejected("this study is closed", 409, closed=True)


def trial_id_of(payload: dict[str, Any]) -> int:
    """The request's ``trial_id``: a whole number an id column can hold."""
    return int_field(payload, "trial_id", Trial.id, required=True)  # type: ignore[return-value]


def validate(
    participant: Participant, payload: dict[str, Any], trial: Trial | None | EllipsisType = ...
) -> tuple[Trial, dict[str, Any]]:
    """Check a vote request against the participant's schedule and the study's rules.
    ``trial``: the request's trial with its vote as :func:`participant_for_vote` read it (None:
    not one of theirs); left out, it is read here."""
    study = participant.study
    check_open(study, pilot=participant.pilot)
    trial_id = trial_id_of(payload)
    if trial is ...:
        # With its vote, if any: a resent or double-clicked vote is answered from it.
        trial = db.session.get(Trial, trial_id, options=[so.joinedload(Trial.vote)])
    return trial, vote_fields(study, trial, participant.id, payload)  # type: ignore[return-value]


def vote_fields(
    study: Any, trial: Any, participant_id: int, payload: dict[str, Any]
) -> dict[str, Any]:
    """The vote's columns from ``payload``, checked against ``trial`` (its ``participant_id``,
    ``kind`` and ``plays``) and the study's rules (``allow_undecided``, ``replay``,
    ``max_plays``, ``settings``); ``study`` and ``trial`` are rows or ORM objects."""
    # Another participant's trial is reported exactly like a missing one: nothing leaks.
    if trial is None or trial.participant_id != participant_id:
        raise VoteRejected("no such trial", 404)
    if trial.kind == "practice":
        raise VoteRejected("the practice pair is not recorded", 422)
    if study.design in RATING_DESIGNS:
        raise VoteRejected(f"this study answers by ratings (design {study.design!r})", 422)
    try:
        choice = str(
            rules.check_choice(payload.get("choice"), undecided_allowed=study.allow_undecided)
        )
    except ValueError as exc:
        raise VoteRejected(f"choice: {exc}") from None
    key = idempotency_key(payload, Vote.idempotency_key)
    claimed = int_field(payload, "plays", Vote.plays, required=True) or 0
    # The server's count wins: a reload cannot give plays back. The page's own count is the
    # fallback only when no play request reached the server (played from its cache offline).
    plays = trial.plays or claimed
    watched = bool(payload.get("watched_to_end", False))
    reason = may_vote(study, plays=plays, watched_to_end=watched)
    if reason:
        raise VoteRejected(reason, 422)
    spec = participation(study)
    return {
        "choice": choice,
        "idempotency_key": key,
        "plays": plays,
        "strength": _strength(payload.get("strength"), choice, spec.scale),
        "reasons": _reasons(payload.get("reasons"), spec.reasons),
        **answer_fields(payload, Vote),
    }


def answer_fields(payload: dict[str, Any], model: Any) -> dict[str, Any]:
    """What every answer (a vote or a rating, ``model`` the stored row's class) carries beside
    its choice: the response time, when the pair was shown and the media log's columns."""
    try:
        columns, log = media_fields(payload.get("media"))
    except MediaLogError as exc:
        raise AnswerRejected(str(exc)) from None
    return {
        "response_ms": int_field(payload, "response_ms", model.response_ms),
        "presented_at": parse_time(payload.get("presented_at")),
        "media": log or None,
        **columns,
    }


def idempotency_key(payload: dict[str, Any], column: Any) -> str:
    """The request's ``idempotency_key``: text of 8 characters up to what ``column`` holds."""
    key = payload.get("idempotency_key")
    longest = limits.column_of(column).type.length
    if not isinstance(key, str) or not 8 <= len(key) <= longest or not limits.fits(column, key):
        raise AnswerRejected(f"idempotency_key: expected text of 8 to {longest} characters")
    return key


def _strength(value: Any, choice: str, scale: int) -> int | None:
    """The 5-level answer's strength: 2 clearly, 1 slightly, 0 for "cannot decide"."""
    if scale == 3:
        if value is not None:
            raise VoteRejected("strength: this study has a 3-level scale")
        return None
    if choice == rules.VoteChoice.UNDECIDED:
        if value not in (None, 0):
            raise VoteRejected("strength: expected 0 with undecided")
        return 0
    if isinstance(value, bool) or value not in (1, 2):
        raise VoteRejected("strength: expected 1 (slightly) or 2 (clearly)")
    return int(value)


def _reasons(value: Any, offered: tuple[str, ...]) -> list[str] | None:
    """The ticked reason tags: distinct, each one of the study's ``reasons``."""
    if value is None or value == []:
        return [] if offered else None
    if (
        not offered
        or not isinstance(value, list)
        or len(value) > len(offered)
        or len(set(map(repr, value))) != len(value)
        or any(v not in offered for v in value)
    ):
        allowed = ", ".join(offered) if offered else "none in this study"
        raise VoteRejected(f"reasons: expected distinct tags from: {allowed}")
    return [str(v) for v in value]


@cache
def _insert_vote(dialect: str) -> sa.Insert:
    """The vote's INSERT, skipped where the trial already has a vote or the key is taken (the
    unique constraints decide, so a race between two requests never raises): one statement
    builder per dialect, whose ``ON CONFLICT DO NOTHING`` both PostgreSQL and SQLite know."""
    insert = postgresql.insert if dialect == "postgresql" else sqlite.insert
    columns = [c for c in Vote.__table__.columns if c.name != "id"]  # type: ignore[attr-defined]
    return (
        insert(Vote)
        .values({c.name: sa.bindparam(c.name, type_=c.type) for c in columns})
        .on_conflict_do_nothing()
        .returning(Vote.id)
    )


def _stored(participant_id: int, trial_id: int, key: str) -> Vote | None:
    """The vote that holds the trial or the key, as committed (a concurrent request's)."""
    return db.session.scalar(
        sa.select(Vote)
        .where(
            sa.or_(
                Vote.idempotency_key == key,
                sa.and_(Vote.participant_id == participant_id, Vote.trial_id == trial_id),
            )
        )
        .limit(1)
    )


class Voter(NamedTuple):
    """A vote's participant (locked) and its trial with its vote (None: not one of theirs)."""

    participant: Participant
    trial: Trial | None


def participant_for_vote(token: Any, trial_id: Any = None) -> Voter | None:
    """The participant whose ``token`` a vote carries, their row locked until the request's
    transaction ends (PostgreSQL; SQLite's writes are serial anyway): one participant's votes
    are stored one after the other, so each sees every earlier one.

    Read in the same round trip: their study, and the trial ``trial_id`` with its vote where
    that trial is theirs, for :func:`record_vote`. A ``trial_id`` that is no id is left for
    :func:`validate` to refuse."""
    if not isinstance(token, str) or not limits.fits(Participant.token, token):
        return None
    try:
        trial_id = trial_id_of({"trial_id": trial_id})
    except AnswerRejected:
        trial_id = None
    row = db.session.execute(_locked_with_trial(), {"token": token, "trial_id": trial_id}).first()
    return None if row is None else Voter(*row)


@cache
def _locked_with_trial() -> sa.Select[tuple[Participant, Trial]]:
    return (
        sa.select(Participant, Trial)
        .join(Participant.study)
        .outerjoin(
            Trial,
            sa.and_(
                Trial.id == sa.bindparam("trial_id", type_=sa.Integer),
                Trial.participant_id == Participant.id,
            ),
        )
        .outerjoin(Trial.vote)
        .options(so.contains_eager(Participant.study), so.contains_eager(Trial.vote))
        .where(Participant.token == sa.bindparam("token"))
        .with_for_update(of=Participant)
    )


def check_answering(participant: Participant) -> None:
    """Refuse any answer (vote or rating) of a participant the attention stop rule ended, or of
    one who still owes the audio check: the trial page sets ``started_at`` only after it, so an
    answer sent without the page is refused while the check is owed."""
    if participant.screened_out_at is not None:
        raise AnswerRejected(SCREENED_OUT, 409, closed=True)
    if participant.started_at is None and audio_check_pending(participant):
        raise AnswerRejected("audio_check: the audio check comes before the first answer", 409)


def record_vote(
    participant: Participant, payload: dict[str, Any], trial: Trial | None | EllipsisType = ...
) -> VoteOutcome:
    """Store the vote in ``payload`` once; the caller commits (one unit of work per request).
    The one path every vote takes, on SQLite and PostgreSQL alike; each change of the
    participant's state is made by its one function (:func:`app.web.study.enrolment.touch`,
    :func:`screen_out`, :func:`app.web.study.participants.release_if_left_out`). ``participant``
    comes from :func:`participant_for_vote` (locked), and ``trial`` with it where it read it.

    Raises :class:`AnswerRejected` for a request that is not a valid vote of this participant:
    a :class:`VoteRejected` for what only a vote is checked for (another participant's trial,
    a bad choice, a key reused on another trial).
    """
    check_answering(participant)
    trial, fields = validate(participant, payload, trial)
    if not touch(participant):
        raise VoteRejected(SESSION_ENDED, 409, closed=True)
    participant_id, trial_id, key = participant.id, trial.id, fields["idempotency_key"]
    created = False
    vote: Vote | StoredVote | None = trial.vote
    if vote is None:
        now = utcnow()
        values = {c: None for c in _VOTE_COLUMNS}
        values.update(fields, participant_id=participant_id, trial_id=trial_id, voted_at=now)
        dialect = db.session.get_bind().dialect.name
        created = db.session.scalar(_insert_vote(dialect), values) is not None
        # Not inserted: a concurrent request stored this trial's vote first, or the key is
        # another trial's; read what holds them.
        vote = StoredVote(trial_id, **{f: fields[f] for f in _ANSWERED}) if created else None
        if vote is None:
            vote = _stored(participant_id, trial_id, key)
            if vote is None:  # pragma: no cover - the constraint held, so the row exists
                raise VoteRejected("the vote could not be stored; send it again", 503)
    if vote.trial_id != trial_id or (
        isinstance(vote, Vote) and vote.participant_id != participant_id
    ):
        raise VoteRejected("idempotency_key: already used for another trial", 409)
    if created and trial.kind == "catch" and fields["choice"] != trial.expected:
        screen_out(participant)
    if created and participant.screened_out_at is None:
        choose_next_pair(participant)  # the adaptive design's next pair; others: no-op
    # The progress and the next pair in one round trip, read after the vote is stored.
    row = db.session.execute(progress_and_upcoming(), {"participant_id": participant_id}).one()
    answered, total = int(row.answered or 0), int(row.total or 0)
    finish_if_done(participant, answered, total)
    # adaptive: the trial after it gets its pair at the next vote, nothing to preload
    following = next_trial_of(
        row, participant, answered, total, preload=participant.study.design != ADAPTIVE
    )
    return VoteOutcome(
        vote=StoredVote(trial_id, *(getattr(vote, f) for f in _ANSWERED)),
        created=created,
        answered=answered,
        total=total,
        upcoming=following,
    )


#: What the answer repeats of a vote besides its trial (:class:`StoredVote`).
_ANSWERED = ("choice", "plays", "response_ms", "strength")
#: The vote's columns but its id: every one is bound by the INSERT.
_VOTE_COLUMNS = tuple(
    c.name
    for c in Vote.__table__.columns  # type: ignore[attr-defined]
    if c.name != "id"
)


def finish_if_done(participant: Participant, answered: int, total: int) -> None:
    """Mark ``participant`` finished once every trial is answered (and give their slot back
    if the report leaves them out); not committed."""
    if (
        answered >= total
        and participant.finished_at is None
        and participant.screened_out_at is None
    ):
        participant.finished_at = utcnow()
        release_if_left_out(participant)


def failed_checks(participant: Participant) -> int:
    """Attention checks (catch trials) ``participant`` answered otherwise than expected (in the
    rating design: rated above the bottom of the scale, :func:`app.trials.rating.catch_ceiling`)."""
    if rated(participant):
        ceiling = catch_ceiling(rating_scale(participant.study))
        return int(
            db.session.scalar(
                sa.select(sa.func.count(Rating.id))
                .join(Trial, Rating.trial_id == Trial.id)
                .where(
                    Rating.participant_id == participant.id,
                    Trial.kind == "catch",
                    Rating.score > ceiling,
                )
            )
            or 0
        )
    return int(
        db.session.scalar(
            sa.select(sa.func.count(Vote.id))
            .join(Trial, Vote.trial_id == Trial.id)
            .where(
                Vote.participant_id == participant.id,
                Trial.kind == "catch",
                Vote.choice != Trial.expected,
            )
        )
        or 0
    )


def screen_out(participant: Participant) -> bool:
    """Apply the stop rule (``attention.max_failed``): end the session once that many checks
    failed. Returns whether the session is now ended; not committed."""
    limit = participation(participant.study).max_failed
    if limit and participant.screened_out_at is None and failed_checks(participant) >= limit:
        participant.screened_out_at = utcnow()
    return participant.screened_out_at is not None
