"""Counting a trial's plays: the page asks for one play before each start of the clip, and the
count kept on the trial is what the study's replay policy (``max_plays``) is held to across
reloads; a vote or rating then takes the server's count over the page's own
(:func:`app.web.study.votes.vote_fields`).

A play is asked for before every clip, so the statements are built once with bound parameters:
one round trip reads the participant's study and the trial, one counts the play unless none is
left.
"""

from __future__ import annotations

from functools import cache
from typing import Any, NamedTuple

import sqlalchemy as sa

from app.trials.rules import play_refusal
from app.web.extensions import db
from app.web.models import Participant, Study, Trial
from app.web.study.votes import replay_policy


class PlayRejected(Exception):
    """No play can be asked for: the token is no participant's (403) or the trial is not one of
    theirs to play (404); ``status`` is the HTTP status."""

    def __init__(self, message: str, status: int) -> None:
        super().__init__(message)
        self.message = message
        self.status = status


class Play(NamedTuple):
    """A play asked for: counted, or refused by the replay policy."""

    #: The trial's plays, this one included when it was counted.
    plays: int
    #: Plays left after this one (None: no limit; 0 when refused).
    left: int | None
    #: Why no play was counted (the replay policy's words), or None when it was.
    refusal: str | None


def is_participant(token: str) -> bool:
    """Whether ``token`` is a participant's."""
    found = db.session.scalar(sa.select(Participant.id).where(Participant.token == token))
    return found is not None


def count_play(token: str, trial_id: int) -> Play:
    """Count one play of trial ``trial_id`` for the participant of ``token``, unless the study's
    replay policy has none left for it; the caller commits (also after a refusal, which
    writes nothing, to end the transaction at once). Raises :class:`PlayRejected` for a token
    that is no participant's, or a trial that is not theirs or is the practice."""
    facts = _one_row(_play_facts(), {"token": token, "trial_id": trial_id})
    if facts is None:
        raise PlayRejected("unknown participant", 403)
    if facts.trial_id is None or facts.kind == "practice":
        raise PlayRejected("no such trial", 404)
    policy = replay_policy(facts)
    limit = policy.max_plays
    counted = _one_row(_one_more_play(), {"trial_id": trial_id, "limit": limit})
    if counted is None:
        plays = _one_row(_plays(), {"trial_id": trial_id}).plays
        return Play(plays, 0, play_refusal(policy))
    return Play(counted.plays, None if limit is None else max(0, limit - counted.plays), None)


@cache
def _play_facts() -> sa.Select[Any]:
    """The participant of a token with their study's replay policy and the trial, if theirs:
    one row, built once (a play is asked for before every clip)."""
    return (
        sa.select(Study.replay, Study.max_plays, Trial.id.label("trial_id"), Trial.kind)
        .select_from(Participant)
        .join(Study, Study.id == Participant.study_id)
        .outerjoin(
            Trial,
            sa.and_(Trial.id == sa.bindparam("trial_id"), Trial.participant_id == Participant.id),
        )
        .where(Participant.token == sa.bindparam("token"))
    )


@cache
def _one_more_play() -> sa.Update:
    """The trial's play count up by one, unless it has reached ``limit`` (None: no limit)."""
    limit = sa.bindparam("limit", type_=sa.Integer)
    return (
        sa.update(Trial)
        .where(Trial.id == sa.bindparam("trial_id"), sa.or_(limit.is_(None), Trial.plays < limit))
        .values(plays=Trial.plays + 1)
        .returning(Trial.plays)
    )


@cache
def _plays() -> sa.Select[tuple[int]]:
    return sa.select(Trial.plays).where(Trial.id == sa.bindparam("trial_id"))


def _one_row(statement: Any, values: dict[str, Any]) -> Any:
    """The one row ``statement`` returns, or None, in the request's transaction."""
    return db.session.execute(statement, values).one_or_none()
