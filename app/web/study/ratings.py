"""Recording a rating exactly once: the one path of the ``rating`` design's answers.

As a vote (:mod:`app.web.study.votes`): the participant's row locked for the request
(:func:`app.web.study.votes.participant_for_vote`), a retried or double-clicked request
carrying the same idempotency key answered with the stored rating, and the unique constraints
on ``rating(participant_id, trial_id, condition_id)`` and ``rating(idempotency_key,
condition_id)`` settling races (the loser's INSERT does nothing and it reads the winner's
row). The replay policy, media log, attention stop rule and finishing are the votes'.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from types import EllipsisType
from typing import Any, NamedTuple

import sqlalchemy as sa
from sqlalchemy.dialects import postgresql, sqlite

from app.trials.design import RATING_DESIGNS
from app.trials.rating import check_score
from app.web.extensions import db
from app.web.models import Participant, Rating, Trial, utcnow
from app.web.study.enrolment import SESSION_ENDED, progress_and_upcoming, touch
from app.web.study.medialog import MediaLogError, media_fields
from app.web.study.participants import rating_scale
from app.web.study.votes import (
    SCREENED_OUT,
    VoteRejected,
    check_open,
    finish_if_done,
    idempotency_key,
    int_field,
    may_vote,
    parse_time,
    screen_out,
    trial_id_of,
)


class StoredRating(NamedTuple):
    """What the answer to a rating repeats of the rating stored for its trial."""

    trial_id: int
    score: int
    plays: int
    response_ms: int | None


@dataclass(frozen=True)
class RatingOutcome:
    rating: StoredRating
    #: True when this request stored it; False when it was already stored (a retry).
    created: bool
    answered: int
    total: int


def rating_fields(participant: Participant, trial: Trial | None, payload: dict[str, Any]) -> dict:
    """The rating's columns from ``payload``, checked against ``trial`` (the participant's,
    not the practice) and the study's scale and replay policy. Raises :class:`VoteRejected`
    with one line naming the field."""
    study = participant.study
    if study.design not in RATING_DESIGNS:
        raise VoteRejected(f"this study answers by votes (design {study.design!r})", 422)
    # Another participant's trial is reported exactly like a missing one: nothing leaks.
    if trial is None or trial.participant_id != participant.id:
        raise VoteRejected("no such trial", 404)
    try:
        score = check_score(rating_scale(study), payload.get("score"))
    except ValueError as exc:
        raise VoteRejected(f"score: {exc}") from None
    key = idempotency_key(payload, Rating.idempotency_key)
    claimed = int_field(payload, "plays", Rating.plays, required=True) or 0
    # The server's count wins (a reload gives no plays back), as for votes.
    plays = trial.plays or claimed
    reason = may_vote(study, plays=plays, watched_to_end=bool(payload.get("watched_to_end")))
    if reason:
        raise VoteRejected(reason, 422)
    try:
        columns, log = media_fields(payload.get("media"))
    except MediaLogError as exc:
        raise VoteRejected(str(exc)) from None
    return {
        "score": score,
        "idempotency_key": key,
        "plays": plays,
        "response_ms": int_field(payload, "response_ms", Rating.response_ms),
        "presented_at": parse_time(payload.get("presented_at")),
        "media": log or None,
        **columns,
    }


@cache
def _insert_rating(dialect: str) -> sa.Insert:
    """The rating's INSERT, skipped where the unique constraints hold one already."""
    insert = postgresql.insert if dialect == "postgresql" else sqlite.insert
    columns = [c for c in Rating.__table__.columns if c.name != "id"]  # type: ignore[attr-defined]
    return (
        insert(Rating)
        .values({c.name: sa.bindparam(c.name, type_=c.type) for c in columns})
        .on_conflict_do_nothing()
        .returning(Rating.id)
    )


#: The rating's columns but its id: every one is bound by the INSERT.
_RATING_COLUMNS = tuple(
    c.name
    for c in Rating.__table__.columns  # type: ignore[attr-defined]
    if c.name != "id"
)


def _stored(participant_id: int, trial_id: int, key: str) -> Rating | None:
    """The rating that holds the trial or the key, as committed (a concurrent request's)."""
    return db.session.scalar(
        sa.select(Rating)
        .where(
            sa.or_(
                Rating.idempotency_key == key,
                sa.and_(Rating.participant_id == participant_id, Rating.trial_id == trial_id),
            )
        )
        .order_by(Rating.id)
        .limit(1)
    )


def record_rating(
    participant: Participant, payload: dict[str, Any], trial: Trial | None | EllipsisType = ...
) -> RatingOutcome:
    """Store the rating in ``payload`` once; the caller commits. ``participant`` comes from
    :func:`app.web.study.votes.participant_for_vote` (locked), ``trial`` with it where read.

    Raises :class:`VoteRejected` for a request that is not a valid rating of this participant.
    """
    if participant.screened_out_at is not None:
        raise VoteRejected(SCREENED_OUT, 409, closed=True)
    check_open(participant.study, pilot=participant.pilot)
    trial_id = trial_id_of(payload)
    if trial is ...:
        trial = db.session.get(Trial, trial_id)
    fields = rating_fields(participant, trial, payload)  # type: ignore[arg-type]
    assert isinstance(trial, Trial)
    if trial.kind == "practice":
        raise VoteRejected("the practice is not recorded", 422)
    if not touch(participant):
        raise VoteRejected(SESSION_ENDED, 409, closed=True)
    key = fields["idempotency_key"]
    stored = _stored(participant.id, trial.id, key)
    created = False
    if stored is None:
        values = {c: None for c in _RATING_COLUMNS}
        values.update(
            fields,
            participant_id=participant.id,
            trial_id=trial.id,
            # the rated condition: the single face the trial's clip shows
            condition_id=trial.stimulus.left_id,
            rated_at=utcnow(),
        )
        dialect = db.session.get_bind().dialect.name
        created = db.session.scalar(_insert_rating(dialect), values) is not None
        if created:
            stored_values = StoredRating(
                trial.id, fields["score"], fields["plays"], fields["response_ms"]
            )
        else:  # a concurrent request stored it first
            stored = _stored(participant.id, trial.id, key)
            if stored is None:  # pragma: no cover - the constraint held, so the row exists
                raise VoteRejected("the rating could not be stored; send it again", 503)
    if stored is not None:
        if stored.trial_id != trial.id or stored.participant_id != participant.id:
            raise VoteRejected("idempotency_key: already used for another trial", 409)
        stored_values = StoredRating(
            stored.trial_id, stored.score, stored.plays, stored.response_ms
        )
    if created and trial.kind == "catch":
        screen_out(participant)
    row = db.session.execute(progress_and_upcoming(True), {"participant_id": participant.id}).one()
    answered, total = int(row.answered or 0), int(row.total or 0)
    finish_if_done(participant, answered, total)
    return RatingOutcome(stored_values, created, answered, total)
