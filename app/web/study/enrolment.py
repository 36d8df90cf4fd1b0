"""Enrolling a participant: balanced list assignment and a reproducible schedule, one transaction.

The list comes from the assignment table (:class:`~app.web.models.StudyList`), never from counting
participant rows: the least-filled list is chosen (``app.trials.assignment.choose_list``) and
its count raised by a conditional UPDATE that only succeeds if nobody raised it meanwhile; on a
lost race the counts are read again (bounded retry). The caller commits, so the count, the
participant and the schedule are stored together or not at all.
"""

from __future__ import annotations

import datetime as dt
from functools import cache, lru_cache
from typing import NamedTuple

import numpy as np
import sqlalchemy as sa
from flask import current_app
from sqlalchemy import orm as so

from app.trials import assignment, design
from app.trials import schedule as schedules
from app.trials.trial import ScheduledTrial
from app.web.extensions import db
from app.web.models import (
    Clip,
    Condition,
    Pair,
    Participant,
    Stimulus,
    Study,
    StudyList,
    Trial,
    utcnow,
)
from app.web.study.progress import progress
from app.web.study.studies import participation, practice_pair

MAX_ATTEMPTS = 20
#: What a dropped participant reads when the study's ``rejoin`` policy refuses their return.
SESSION_ENDED = (
    "your session ended after a long pause, and your place was given to another "
    "participant; thank you for your time"
)


class EnrolmentBusy(RuntimeError):
    """Too many simultaneous arrivals; the participant should simply retry."""


class Design(NamedTuple):
    """What every consent reads of a study's design: fixed once the study is created
    (:func:`app.web.study.studies.create_study` writes these rows, only
    :func:`app.web.study.studies.delete_study` removes them), so it is read once per process
    (:func:`study_design`)."""

    #: Clip names in the stored order, and each one's id.
    clip_names: tuple[str, ...]
    clips: dict[str, int]
    #: Condition name -> id.
    conditions: dict[str, int]
    #: The pairs in the stored order, by condition names.
    pairs: tuple[design.ConditionPair, ...]
    #: (first condition id, second condition id) -> pair id, either way round.
    pair_ids: dict[tuple[int, int], int]
    n_lists: int
    #: (clip id, left id, right id, instruction, foreign side) -> stimulus id.
    stimuli: dict[tuple[int, int, int, str | None, str | None], int]


def study_design(study: Study) -> Design:
    """The study's :class:`Design`, read in four plain queries the first time in this process
    and kept for the 64 studies used last, instead of the ORM's lazy relationships on every
    consent."""
    return _design(study.id, study.slug)


@lru_cache(maxsize=64)
def _design(study_id: int, slug: str) -> Design:
    """Kept by study id and slug: the slug, random for every study created, tells apart a
    study created later under a reused id (SQLite may reuse a deleted row's id, and a database
    created again starts its ids afresh)."""
    return _read_design(study_id)


def _read_design(study_id: int) -> Design:
    run = db.session.execute
    clips = run(
        sa.select(Clip.name, Clip.id).where(Clip.study_id == study_id).order_by(Clip.position)
    ).all()
    conditions = dict(
        run(sa.select(Condition.name, Condition.id).where(Condition.study_id == study_id)).all()
    )
    names = {condition_id: name for name, condition_id in conditions.items()}
    pairs = run(
        sa.select(Pair.id, Pair.first_id, Pair.second_id)
        .where(Pair.study_id == study_id)
        .order_by(Pair.position)
    ).all()
    pair_ids: dict[tuple[int, int], int] = {}
    for pair in pairs:
        pair_ids.setdefault((pair.first_id, pair.second_id), pair.id)
    for pair in pairs:
        pair_ids.setdefault((pair.second_id, pair.first_id), pair.id)
    n_lists = run(
        sa.select(sa.func.count(StudyList.id)).where(StudyList.study_id == study_id)
    ).scalar_one()
    stimuli = {
        (s.clip_id, s.left_id, s.right_id, s.instruction, s.foreign_side): s.id
        for s in run(
            sa.select(
                Stimulus.id,
                Stimulus.clip_id,
                Stimulus.left_id,
                Stimulus.right_id,
                Stimulus.instruction,
                Stimulus.foreign_side,
            ).where(Stimulus.study_id == study_id)
        )
    }
    return Design(
        clip_names=tuple(name for name, _ in clips),
        clips=dict(clips),
        conditions=conditions,
        pairs=tuple(design.ConditionPair(names[p.first_id], names[p.second_id]) for p in pairs),
        pair_ids=pair_ids,
        n_lists=int(n_lists),
        stimuli=stimuli,
    )


def schedule(study: Study, *, seed: int, list_index: int) -> list[ScheduledTrial]:
    """One participant's trials (:class:`app.trials.trial.ScheduledTrial`), in presentation
    order."""
    settings = study.settings or {}
    fixed = study_design(study)
    return schedules.make_schedule(
        clips=list(fixed.clip_names),
        pairs=list(fixed.pairs),
        design=study.design,
        seed=seed,
        list_index=list_index,
        n_lists=fixed.n_lists,
        catch_trials=study.catch_trials,
        catch_kind=study.catch_kind,
        practice_pair=practice_pair(study),
        practice_clip=settings.get("practice_clip"),
        block_by_clip=settings.get("block_by_clip", True),
        mismatched=participation(study).mismatched,
        reference=study.reference,
    )


def participant_seed(study: Study, number: int) -> int:
    """The schedule seed of the study's participant ``number``."""
    return int(schedules.participant_seed(study.seed, number))


def choose_list(study: Study, counts: dict[int, int]) -> int:
    """The least-filled list; ties broken by a generator seeded from the study and arrivals."""
    rng = np.random.default_rng([study.seed, sum(counts.values())])
    return int(assignment.choose_list(counts, rng))


def _take_list(study: Study) -> tuple[int, int, int]:
    """Raise the count of the least-filled list; returns its id, its index and its arrivals
    before.

    On PostgreSQL each attempt is a savepoint: an UPDATE that waited for another arrival's
    and then found the count changed has still locked the row (the newest version is locked
    before the condition is checked again), and two arrivals each holding a lost list while
    trying the other's deadlocked (20 consents at once to 4 workers: 5 to 7 answered 503).
    Rolling back to the savepoint lets that lock go."""
    savepoints = db.engine.dialect.name == "postgresql"
    for _ in range(MAX_ATTEMPTS):
        rows = db.session.execute(
            sa.select(
                StudyList.id, StudyList.index, StudyList.n_assigned, StudyList.n_arrived
            ).where(StudyList.study_id == study.id)
        ).all()
        counts = {row.index: row.n_assigned for row in rows}
        index = choose_list(study, counts)
        row = next(r for r in rows if r.index == index)
        attempt = db.session.begin_nested() if savepoints else None
        # n_arrived only grows, so this guard cannot be fooled by a release in between.
        result = db.session.execute(
            sa.update(StudyList)
            .where(
                StudyList.id == row.id,
                StudyList.n_assigned == row.n_assigned,
                StudyList.n_arrived == row.n_arrived,
            )
            .values(n_assigned=StudyList.n_assigned + 1, n_arrived=StudyList.n_arrived + 1)
            .execution_options(synchronize_session=False)
        )
        if result.rowcount == 1:
            if attempt is not None:
                attempt.commit()
            return row.id, row.index, row.n_arrived
        if attempt is not None:
            attempt.rollback()
    raise EnrolmentBusy("too many participants arriving at once; please reload the page")


def enrol(
    study: Study,
    *,
    user_agent: str = "",
    prolific_pid: str | None = None,
    prolific_study_id: str | None = None,
    prolific_session_id: str | None = None,
    dropped_after: dt.timedelta | None = None,
    unstarted: dt.timedelta | None = None,
) -> Participant:
    """Create a participant with a list, a seed and a schedule (not committed).

    With ``dropped_after``, participants idle longer than that (and, with ``unstarted``,
    those who never started for that long) give their slots back first
    (:func:`release_dropped`), so the new arrival is balanced over those still taking part.
    """
    if dropped_after is not None:
        release_dropped(study, after=dropped_after, unstarted_after=unstarted)
    fixed = study_design(study)
    list_id, list_index, before = _take_list(study)
    # (list, arrivals before) is unique per study, so this arrival number is too.
    number = before * fixed.n_lists + list_index
    seed = participant_seed(study, number)
    participant = Participant(
        study_id=study.id,
        list_id=list_id,
        number=number,
        seed=seed,
        user_agent=user_agent,
        prolific_pid=prolific_pid,
        prolific_study_id=prolific_study_id,
        prolific_session_id=prolific_session_id,
    )
    db.session.add(participant)
    db.session.flush()
    clips, conditions = fixed.clips, fixed.conditions
    rows = []
    for item in schedule(study, seed=seed, list_index=list_index):
        left, right = conditions[item.left], conditions[item.right]
        rows.append(
            {
                "participant_id": participant.id,
                "position": item.position,
                "kind": item.kind,
                "expected": item.expected,
                "pair_id": fixed.pair_ids.get((left, right)),
                "stimulus_id": fixed.stimuli[
                    (clips[item.clip], left, right, item.instruction, item.foreign)
                ],
            }
        )
    db.session.execute(sa.insert(Trial), rows)
    return participant


#: The columns of a participant's state that a sign of life reads back, in the same round trip
#: as its UPDATE (a concurrent request of theirs may have changed them since the row was read).
_STATE = ("last_seen_at", "finished_at", "dropped_at", "screened_out_at", "excluded_at")


@cache
def _seen() -> sa.Update:
    return (
        sa.update(Participant)
        .where(Participant.id == sa.bindparam("participant_id"), Participant.dropped_at.is_(None))
        .values(last_seen_at=sa.bindparam("now"))
        .returning(*(getattr(Participant, name) for name in _STATE))
    )


def practice_stimulus(participant: Participant) -> Stimulus | None:
    """The clip of the practice pair on the instructions page (votes on it are never stored):
    the schedule's practice trial, or None when the schedule has none (``practice = false``,
    and the rating designs). No other clip stands in for it: that would show a practice the
    study file turned off, and one of the study's own pairs before its trial."""
    practice = db.session.scalar(
        sa.select(Trial)
        .where(Trial.participant_id == participant.id, Trial.kind == "practice")
        .limit(1)
    )
    return practice.stimulus if practice is not None else None


def release_dropped(
    study: Study, *, after: dt.timedelta, unstarted_after: dt.timedelta | None = None
) -> int:
    """Mark unfinished participants idle for longer than ``after`` as dropped and give their
    list slots back (thesis-style balance over those who actually take part); those who
    consented but never started a trial go after ``unstarted_after`` already (a burst of
    consents that never start must not hold the lists for long).

    The candidates are read through the partial index ``ix_participant_active`` (study, last
    request) over unfinished, undropped participants only, so the cost follows the number of
    participants taking part now, not the study's size. Each release is a conditional UPDATE
    that re-checks idleness on the row as it stands, so a participant whose vote lands at the
    same moment is never both active and released, and two releases never give one slot back
    twice.
    """
    now = utcnow()
    cutoff = now - after
    early = now - min(unstarted_after, after) if unstarted_after is not None else cutoff
    idle = sa.or_(
        Participant.last_seen_at < cutoff,
        sa.and_(Participant.started_at.is_(None), Participant.last_seen_at < early),
    )
    stale = db.session.execute(
        sa.select(Participant.id, Participant.list_id).where(
            Participant.study_id == study.id,
            Participant.finished_at.is_(None),
            Participant.dropped_at.is_(None),
            Participant.last_seen_at < early,
            idle,
        )
    ).all()
    released = 0
    for participant_id, list_id in stale:
        result = db.session.execute(
            sa.update(Participant)
            .where(
                Participant.id == participant_id,
                Participant.finished_at.is_(None),
                Participant.dropped_at.is_(None),
                idle,
            )
            .values(dropped_at=utcnow())
            .execution_options(synchronize_session=False)
        )
        if result.rowcount == 1:
            move_slot(list_id, -1)
            released += 1
    if released:
        db.session.expire_all()
    return released


def move_slot(list_id: int, change: int) -> None:
    """Raise (+1, a participant takes a slot) or lower (-1, gives it back) a list's count."""
    db.session.execute(
        sa.update(StudyList)
        .where(StudyList.id == list_id)
        .values(n_assigned=StudyList.n_assigned + change)
        .execution_options(synchronize_session=False)
    )


def dropped_after() -> dt.timedelta:
    """The deployment's idle time after which an unfinished participant counts as dropped."""

    return dt.timedelta(minutes=current_app.config["DROPPED_AFTER_MINUTES"])


def unstarted_after() -> dt.timedelta:
    """The deployment's time after which a participant who consented but never started a
    trial gives their list slot back."""
    return dt.timedelta(minutes=current_app.config["UNSTARTED_AFTER_MINUTES"])


def rejoin_policy(study: Study) -> str:
    """What a dropped participant meets on coming back: the study file's ``rejoin``."""
    return str((study.settings or {}).get("rejoin", "resume"))


def touch(participant: Participant) -> bool:
    """A sign of life from ``participant``: last seen now. A participant released as dropped
    takes their list slot back, unless the study's ``rejoin`` policy is ``refuse``: then
    nothing changes and the answer is False (their session has ended).

    Both steps are conditional UPDATEs on the participant row, so a release and a return
    racing each other leave the row and the list count agreeing: a participant holds a slot
    exactly when ``dropped_at`` is empty. Not committed: the caller's unit of work decides.
    """
    now = utcnow()
    # RETURNING the state refreshes ``participant`` in the same round trip as the UPDATE; set as
    # committed values, so the rest of the object (its study, loaded with it) stays loaded.
    present = db.session.execute(
        _seen(),
        {"participant_id": participant.id, "now": now},
        execution_options={"synchronize_session": False},
    ).first()
    if present is not None:
        for name, value in zip(_STATE, present, strict=True):
            so.attributes.set_committed_value(participant, name, value)
        return True
    # The row as it is now: a concurrent request of theirs may have finished them since it
    # was read (SQLite reads without a lock).
    db.session.refresh(participant)
    if participant.finished_at is not None:
        # Finished, and released because the report leaves them out: a resent last vote or a
        # late request, not a return from a pause. Nothing to rejoin, no slot to take back.
        return True
    if rejoin_policy(participant.study) == "refuse":
        return False
    returned = db.session.execute(
        sa.update(Participant)
        # An excluded participant's or a pilot's slot stays given back.
        .where(
            Participant.id == participant.id,
            Participant.dropped_at.is_not(None),
            Participant.excluded_at.is_(None),
            Participant.pilot.is_(False),
            Participant.finished_at.is_(None),
        )
        .values(last_seen_at=now, dropped_at=None)
        .execution_options(synchronize_session=False)
    )
    if returned.rowcount == 1:
        move_slot(participant.list_id, +1)
    db.session.refresh(participant)
    return True


def touch_with_progress(participant: Participant) -> tuple[int, int] | None:
    """:func:`touch`, then :func:`progress`: (answered, total), or None where ``touch`` says
    the participant's session has ended. Not committed."""
    if not touch(participant):
        return None
    return progress(participant)
