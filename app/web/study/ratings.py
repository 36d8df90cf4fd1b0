"""Recording a rating exactly once: the one path of the rating designs' answers (one score
in ``rating``, one per item in ``parallel``, all of a trial stored together).

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
from app.trials.rating import check_score, parallel_order
from app.web.extensions import db
from app.web.models import Condition, Participant, Rating, Trial, utcnow
from app.web.study.enrolment import SESSION_ENDED, touch
from app.web.study.progress import next_trial_of, progress_and_upcoming
from app.web.study.studies import rating_scale
from app.web.study.votes import (
    AnswerRejected,
    answer_fields,
    check_answering,
    check_open,
    finish_if_done,
    idempotency_key,
    int_field,
    may_vote,
    screen_out,
    trial_id_of,
)


class RatingRejected(AnswerRejected):
    """The request cannot be a rating of this participant."""


class StoredRating(NamedTuple):
    """What the answer to a rating repeats of the ratings stored for its trial."""

    trial_id: int
    #: Condition id -> score: the trial's one condition (``rating``), or every item
    #: (``parallel``).
    scores: dict[int, int]
    plays: int
    response_ms: int | None


@dataclass(frozen=True)
class RatingOutcome:
    rating: StoredRating
    #: True when this request stored it; False when it was already stored (a retry).
    created: bool
    answered: int
    total: int
    #: The next trial as the rating page shows it (:func:`app.web.study.progress.next_trial_of`),
    #: None when there is none to show (every trial answered, screened out).
    upcoming: Any = None


def rating_fields(participant: Participant, trial: Trial | None, payload: dict[str, Any]) -> dict:
    """The rating's columns from ``payload``, checked against ``trial`` (the participant's,
    not the practice) and the study's scale and replay policy. Raises :class:`RatingRejected`
    (:class:`app.web.study.votes.AnswerRejected` for the fields every answer carries) with one
    line naming the field."""
    study = participant.study
    if study.design not in RATING_DESIGNS:
        raise RatingRejected(f"this study answers by votes (design {study.design!r})", 422)
    # Another participant's trial is reported exactly like a missing one: nothing leaks.
    if trial is None or trial.participant_id != participant.id:
        raise RatingRejected("no such trial", 404)
    scores = _scores(participant, trial, payload)
    key = idempotency_key(payload, Rating.idempotency_key)
    claimed = int_field(payload, "plays", Rating.plays, required=True) or 0
    # The server's count wins (a reload gives no plays back), as for votes.
    plays = trial.plays or claimed
    if study.design == "parallel" and plays < len(scores):
        # BS.1534 asks for every item to be heard: at least one play each
        raise RatingRejected(f"plays: every item is played first ({plays} of {len(scores)})", 422)
    reason = may_vote(study, plays=plays, watched_to_end=bool(payload.get("watched_to_end")))
    if reason:
        raise RatingRejected(reason, 422)
    return {
        "scores": scores,
        "idempotency_key": key,
        "plays": plays,
        **answer_fields(payload, Rating),
    }


def shown_items(participant: Participant, trial: Trial) -> list[Condition]:
    """A ``parallel`` trial's items in the order its page shows them
    (:func:`app.trials.rating.parallel_order` of the study's conditions)."""
    conditions = participant.study.conditions
    order = parallel_order(
        [c.name for c in conditions], seed=participant.seed, position=trial.position
    )
    by_name = {c.name: c for c in conditions}
    return [by_name[name] for name in order]


def _scores(participant: Participant, trial: Trial, payload: dict[str, Any]) -> dict[int, int]:
    """Condition id -> score from ``payload``: its ``score`` of the trial's one face
    (``rating``), or its ``scores``, one per item in the order shown (``parallel``)."""
    scale = rating_scale(participant.study)
    if participant.study.design != "parallel":
        try:
            return {trial.stimulus.left_id: check_score(scale, payload.get("score"))}
        except ValueError as exc:
            raise RatingRejected(f"score: {exc}") from None
    items = shown_items(participant, trial)
    given = payload.get("scores")
    if not isinstance(given, list) or len(given) != len(items):
        raise RatingRejected(f"scores: expected a list of {len(items)} scores, one per item")
    out = {}
    for index, (item, value) in enumerate(zip(items, given, strict=True)):
        try:
            out[item.id] = check_score(scale, value)
        except ValueError as exc:
            raise RatingRejected(f"scores[{index}]: {exc}") from None
    return out


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


def _stored(participant_id: int, trial_id: int, key: str) -> list[Rating]:
    """The ratings that hold the trial or the key, as committed (a concurrent request's)."""
    return list(
        db.session.scalars(
            sa.select(Rating)
            .where(
                sa.or_(
                    Rating.idempotency_key == key,
                    sa.and_(Rating.participant_id == participant_id, Rating.trial_id == trial_id),
                )
            )
            .order_by(Rating.id)
        )
    )


def record_rating(
    participant: Participant, payload: dict[str, Any], trial: Trial | None | EllipsisType = ...
) -> RatingOutcome:
    """Store the rating in ``payload`` once; the caller commits. ``participant`` comes from
    :func:`app.web.study.votes.participant_for_vote` (locked), ``trial`` with it where read.

    Raises :class:`app.web.study.votes.AnswerRejected` for a request that is not a valid
    rating of this participant: a :class:`RatingRejected` for what only a rating is checked for.
    """
    check_answering(participant)
    check_open(participant.study, pilot=participant.pilot)
    trial_id = trial_id_of(payload)
    if trial is ...:
        trial = db.session.get(Trial, trial_id)
    fields = rating_fields(participant, trial, payload)  # type: ignore[arg-type]
    assert isinstance(trial, Trial)
    if trial.kind == "practice":
        raise RatingRejected("the practice is not recorded", 422)
    if not touch(participant):
        raise RatingRejected(SESSION_ENDED, 409, closed=True)
    key = fields["idempotency_key"]
    stored = _stored(participant.id, trial.id, key)
    created = False
    if not stored:
        dialect = db.session.get_bind().dialect.name
        for condition_id, score in fields["scores"].items():
            values = {c: None for c in _RATING_COLUMNS}
            values.update(
                {k: v for k, v in fields.items() if k != "scores"},
                participant_id=participant.id,
                trial_id=trial.id,
                condition_id=condition_id,
                score=score,
                rated_at=utcnow(),
            )
            created = db.session.scalar(_insert_rating(dialect), values) is not None or created
        if not created:  # a concurrent request stored them first
            stored = _stored(participant.id, trial.id, key)
            if not stored:  # pragma: no cover - the constraint held, so the rows exist
                raise RatingRejected("the rating could not be stored; send it again", 503)
    if stored:
        if any(r.trial_id != trial.id or r.participant_id != participant.id for r in stored):
            raise RatingRejected("idempotency_key: already used for another trial", 409)
        first = stored[0]
        kept = StoredRating(
            trial.id, {r.condition_id: r.score for r in stored}, first.plays, first.response_ms
        )
    else:
        kept = StoredRating(trial.id, fields["scores"], fields["plays"], fields["response_ms"])
    if created and trial.kind == "catch":
        screen_out(participant)
    row = db.session.execute(progress_and_upcoming(True), {"participant_id": participant.id}).one()
    answered, total = int(row.answered or 0), int(row.total or 0)
    finish_if_done(participant, answered, total)
    # the parallel design plays a trial's versions from their own URLs: nothing to preload
    preload = participant.study.design != "parallel"
    upcoming = next_trial_of(row, participant, answered, total, preload=preload)
    return RatingOutcome(kept, created, answered, total, upcoming)
