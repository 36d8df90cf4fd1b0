"""A participant's way through their schedule: the next trials without an answer, the one the
trial page shows with the trial after it, and the progress counts.

Every trial page and every answer asks for these, so the statements are built once with bound
parameters (``participant_id``) and the next trial and the counts are read in one round trip
after an answer is stored (:func:`progress_and_upcoming`): the answer carries the next trial
(:func:`next_trial_of`) and the page goes on to it in place (``static/pair.js``,
``static/rating.js``). A study holds votes or ratings, never both (:func:`rated`).
"""

from __future__ import annotations

from functools import cache
from types import SimpleNamespace
from typing import Any

import sqlalchemy as sa

from app.trials.design import RATING_DESIGNS
from app.web.extensions import db
from app.web.models import Participant, Rating, Stimulus, Trial, Vote


def next_trial(participant: Participant) -> Trial | None:
    """The participant's first trial without a vote (where a reload resumes)."""
    found = next_trials(participant, 1)
    return found[0] if found else None


def next_trials(participant: Participant, count: int) -> list[Trial]:
    """The participant's first ``count`` trials without an answer, in schedule order."""
    return list(
        db.session.scalars(
            _unanswered(rated(participant)), {"participant_id": participant.id, "count": count}
        )
    )


def rated(participant: Participant) -> bool:
    """Whether ``participant``'s answers are ratings (:class:`Rating`), not votes: a study
    holds one kind only, so each design's statements read only its own answers' table."""
    return participant.study.design in RATING_DESIGNS


# The statements every trial page and vote runs are built once, with bound parameters.


def _without_vote(select: Any, rated: bool = False) -> Any:
    """``select`` narrowed to the bound ``participant_id``'s trials without a vote (``rated``:
    without a rating; one per trial in the ``rating`` design), in order.

    The votes joined are the participant's own (a trial's vote is always its participant's):
    PostgreSQL then reads them by index, where joining on the trial alone scans every vote of
    every participant."""
    who = sa.bindparam("participant_id")
    answer = Rating if rated else Vote
    return (
        select.outerjoin(answer, sa.and_(answer.participant_id == who, answer.trial_id == Trial.id))
        .where(Trial.participant_id == who, Trial.kind != "practice", answer.id.is_(None))
        .order_by(Trial.position)
    )


@cache
def _unanswered(rated: bool = False) -> sa.Select[tuple[Trial]]:
    return _without_vote(sa.select(Trial), rated).limit(sa.bindparam("count", type_=sa.Integer))


@cache
def upcoming(rated: bool = False) -> sa.Select[Any]:
    """The bound participant's next trial without a vote, as the trial page shows it: one
    row (none when every trial is answered) with what the page needs of it (its plays, kind,
    expected answer, its stimulus's on-screen instruction and WebM rendition) and the id of
    the trial after it, whose clip is preloaded (NULL when it is the last), with its WebM.
    The vote's answer carries it (:func:`app.web.study.votes.record_vote`), so the browser
    needs no trial page per pair. One pass over the participant's trials: the one after comes
    from ``lead`` over the same rows, and the instruction and WebMs are read for the one row
    kept."""
    pending = (
        _without_vote(
            sa.select(
                Trial.id.label("trial_id"),
                Trial.plays,
                Trial.kind,
                Trial.expected,
                Trial.stimulus_id,
                sa.func.lead(Trial.id).over(order_by=Trial.position).label("following"),
                sa.func.lead(Trial.stimulus_id)
                .over(order_by=Trial.position)
                .label("following_stimulus_id"),
            ),
            rated,
        )
        .limit(1)
        .subquery("pending")
    )
    instruction = (
        sa.select(Stimulus.instruction)
        .where(Stimulus.id == pending.c.stimulus_id)
        .scalar_subquery()
        .label("instruction")
    )

    def webm(stimulus_id: Any, name: str) -> Any:
        return (
            sa.select(Stimulus.webm_path)
            .where(Stimulus.id == stimulus_id)
            .scalar_subquery()
            .label(name)
        )

    return sa.select(
        pending.c.trial_id,
        pending.c.plays,
        pending.c.kind,
        pending.c.expected,
        instruction,
        pending.c.following,
        webm(pending.c.stimulus_id, "webm"),
        webm(pending.c.following_stimulus_id, "following_webm"),
    )


@cache
def progress_and_upcoming(rated: bool = False) -> sa.Select[Any]:
    """:func:`progress_counts` and :func:`upcoming`'s columns in one row, for the bound
    ``participant_id``: (answered, total, trial_id, plays, kind, expected, instruction,
    following, webm, following_webm), the upcoming columns NULL when every trial is
    answered. What a vote's answer
    needs, read in one round trip after the vote is stored."""
    answered, total = progress_counts(rated)
    counts_row = sa.select(answered.label("answered"), total.label("total")).subquery("progress")
    pending = upcoming(rated).subquery("next_pair")
    return sa.select(counts_row, *pending.c).select_from(counts_row.outerjoin(pending, sa.true()))


def next_trial_of(
    row: Any, participant: Participant, answered: int, total: int, *, preload: bool = True
) -> SimpleNamespace | None:
    """The next trial in a :func:`progress_and_upcoming` row, as an answer carries it to the
    page (its id, plays, kind, expected answer, instruction and the trial after it, None where
    ``preload`` is false; ``webm`` and ``following_webm``: whether each has its WebM), or
    None: every trial answered, the participant screened out, or no trial left unanswered."""
    if answered >= total or participant.screened_out_at is not None or row.trial_id is None:
        return None
    return SimpleNamespace(
        trial_id=row.trial_id,
        plays=row.plays,
        kind=row.kind,
        expected=row.expected,
        instruction=row.instruction,
        following=row.following if preload else None,
        webm=row.webm is not None,
        following_webm=preload and row.following_webm is not None,
    )


def progress_counts(
    rated: bool | None = False,
) -> tuple[sa.ScalarSelect[int], sa.ScalarSelect[int]]:
    """(answered, total) as scalar subqueries on the bound ``participant_id``: the votes (the
    ratings where ``rated``; both where it is None, for a caller that does not know the
    design), and the real and catch trials (not the practice). The one definition of a
    participant's progress (:func:`progress`)."""
    who = sa.bindparam("participant_id")

    def count(answer: type[Vote] | type[Rating]) -> sa.ScalarSelect[int]:
        # a parallel trial holds one rating per item: its trials are counted
        counted = sa.distinct(Rating.trial_id) if answer is Rating else Vote.id
        return (
            sa.select(sa.func.count(counted)).where(answer.participant_id == who).scalar_subquery()
        )

    answered = count(Vote) + count(Rating) if rated is None else count(Rating if rated else Vote)
    total = (
        sa.select(sa.func.count(Trial.id))
        .where(Trial.participant_id == who, Trial.kind != "practice")
        .scalar_subquery()
    )
    return answered, total


@cache
def _progress() -> sa.Select[tuple[int, int]]:
    return sa.select(*progress_counts(None))


def progress(participant: Participant) -> tuple[int, int]:
    """(answered, total) over the participant's real and catch trials (not the practice)."""
    # One round trip for both counts: every vote and every trial page asks for them.
    # Votes and ratings both (a study holds one kind): the study need not be read for it.
    row = db.session.execute(_progress(), {"participant_id": participant.id}).one()
    return int(row[0] or 0), int(row[1] or 0)
