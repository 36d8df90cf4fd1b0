"""The live monitor of a study: how many participants have each status, votes per pair (or,
in the rating designs, ratings per condition, and in the ``parallel`` design whom the
hidden-reference post-screening would leave out), timings."""

from __future__ import annotations

import datetime as dt
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import pandas as pd
import sqlalchemy as sa

from app.analysis.rating_results import (
    REFERENCE_BELOW,
    REFERENCE_SHARE,
    post_screening,
    screening_rule,
)
from app.trials.design import RATING_DESIGNS
from app.trials.rating import catch_passed
from app.trials.rules import CHOICES, VoteChoice
from app.web.extensions import db
from app.web.models import (
    Condition,
    Participant,
    Rating,
    Stimulus,
    Study,
    StudyList,
    Trial,
    Vote,
    utcnow,
)
from app.web.study.enrolment import dropped_after as dropped_after_setting
from app.web.study.participants import STATUSES, participant_table, status_of
from app.web.study.studies import rating_scale


@dataclass
class PairStats:
    label: str
    votes: int = 0
    choices: dict[str, int] = field(default_factory=lambda: dict.fromkeys(CHOICES, 0))
    #: Votes for the pair's first / second condition, whichever side it was shown on.
    first: int = 0
    second: int = 0
    median_ms: float | None = None


def study_monitor(study: Study, *, dropped_after: dt.timedelta) -> dict[str, Any]:
    """Counts and per-pair tallies: ``joined`` and the participants of each status
    (``statuses``, by :func:`app.web.study.participants.status_of`; ``dropped`` = unfinished
    and idle longer than ``dropped_after``, or already released). Pilot participants are not
    counted (the participant table lists them)."""
    now = utcnow()
    participants = db.session.scalars(
        sa.select(Participant).where(Participant.study_id == study.id, Participant.pilot.is_(False))
    ).all()
    statuses = dict.fromkeys(STATUSES, 0)
    for person in participants:
        statuses[status_of(person, now=now, dropped_after=dropped_after)] += 1
    rating = (
        rating_monitor(study, dropped_after=dropped_after)
        if study.design in RATING_DESIGNS
        else None
    )
    # a rating study has no votes: its times and checks are its ratings'
    pairs, median_ms, catch = (
        ([], rating["median_ms"], rating["checks"]) if rating else _pair_tallies(study)
    )
    lists = db.session.execute(
        sa.select(StudyList.index, StudyList.n_assigned)
        .where(StudyList.study_id == study.id)
        .order_by(StudyList.index)
    ).all()
    return {
        "joined": len(participants),
        "statuses": statuses,
        "target": study.target_participants,
        "votes": sum(s.votes for s in pairs),
        "median_ms": median_ms,
        "pairs": pairs,
        "catch": catch,
        "lists": [{"index": i, "assigned": n} for i, n in lists],
        "rating": rating,
    }


def _pair_tallies(study: Study) -> tuple[list[PairStats], float | None, dict[str, int]]:
    """The pair designs' votes, pilots left out: each pair's tally (by choice, and for the
    pair's first or second condition whichever side it was shown on) with its median response
    time, the median time over all votes, and the catch trials answered as expected."""
    pairs = {p.id: PairStats(p.label) for p in study.pairs}
    first_of = {p.id: p.first_id for p in study.pairs}
    times: dict[int, list[int]] = {pid: [] for pid in pairs}
    all_times: list[int] = []
    catch_total = catch_passed = 0
    query = (
        sa.select(
            Vote.choice,
            Vote.response_ms,
            Trial.pair_id,
            Trial.kind,
            Trial.expected,
            Trial.stimulus_id,
        )
        .join(Trial, Vote.trial_id == Trial.id)
        .join(Participant, Vote.participant_id == Participant.id)
        .where(Participant.study_id == study.id, Participant.pilot.is_(False))
    )
    left_of = dict(
        db.session.execute(
            sa.select(Stimulus.id, Stimulus.left_id).where(Stimulus.study_id == study.id)
        ).all()
    )
    for choice, response_ms, pair_id, kind, expected, stimulus_id in db.session.execute(query):
        if response_ms is not None:
            all_times.append(response_ms)
        if kind == "catch":
            catch_total += 1
            catch_passed += choice == expected
            continue
        if pair_id is None or pair_id not in pairs:
            continue
        stats = pairs[pair_id]
        stats.votes += 1
        stats.choices[choice] = stats.choices.get(choice, 0) + 1
        if choice != VoteChoice.UNDECIDED:
            chosen_left = choice == VoteChoice.LEFT
            first_on_left = left_of[stimulus_id] == first_of[pair_id]
            if chosen_left == first_on_left:
                stats.first += 1
            else:
                stats.second += 1
        if response_ms is not None:
            times[pair_id].append(response_ms)
    for pair_id, values in times.items():
        if values:
            pairs[pair_id].median_ms = statistics.median(values)
    median_ms = statistics.median(all_times) if all_times else None
    return list(pairs.values()), median_ms, {"total": catch_total, "passed": catch_passed}


def rating_monitor(study: Study, *, dropped_after: dt.timedelta | None = None) -> dict[str, Any]:
    """The rating designs' live tallies: for each condition, in the study's order, the ratings
    of real trials so far, their raw mean score (the report's MOS comes from the mixed model)
    and the median time to rate; and the checks rated and passed (a check asks for the
    scale's lowest level: ``app.trials.rating.catch_passed``). Pilots are not counted. In the
    ``parallel`` design ``screening`` says whom the hidden-reference post-screening would
    leave out of a report written now (:func:`reference_screening_now`); None otherwise."""
    rows = db.session.execute(
        sa.select(
            Rating.participant_id,
            Rating.condition_id,
            Rating.score,
            Rating.response_ms,
            Trial.kind,
        )
        .join(Trial, Rating.trial_id == Trial.id)
        .join(Participant, Rating.participant_id == Participant.id)
        .where(Participant.study_id == study.id, Participant.pilot.is_(False))
    ).all()
    scale = rating_scale(study)
    conditions = db.session.scalars(
        sa.select(Condition).where(Condition.study_id == study.id).order_by(Condition.position)
    ).all()
    scores: dict[int, list[int]] = {c.id: [] for c in conditions}
    times: dict[int, list[int]] = {c.id: [] for c in conditions}
    checks = passed = 0
    every_time = [r.response_ms for r in rows if r.response_ms is not None]
    for _, condition_id, score, response_ms, kind in rows:
        if kind == "catch":
            checks += 1
            passed += catch_passed(scale, score)
        elif condition_id in scores:
            scores[condition_id].append(score)
            if response_ms is not None:
                times[condition_id].append(response_ms)
    screening = None
    if study.design == "parallel":
        reference = next((c.id for c in conditions if c.name == study.reference), None)
        screening = reference_screening_now(
            study, rows, reference, dropped_after=dropped_after or dropped_after_setting()
        )
    return {
        "ratings": sum(len(v) for v in scores.values()),
        "conditions": [
            {
                "name": c.name,
                "ratings": len(scores[c.id]),
                "mean": statistics.fmean(scores[c.id]) if scores[c.id] else None,
                "median_ms": statistics.median(times[c.id]) if times[c.id] else None,
            }
            for c in conditions
        ],
        "checks": {"total": checks, "passed": passed},
        "median_ms": statistics.median(every_time) if every_time else None,
        "screening": screening,
    }


def reference_screening_now(
    study: Study, rows: Sequence[Any], reference: int | None, *, dropped_after: dt.timedelta
) -> dict[str, Any]:
    """Whom the hidden-reference post-screening (``app.analysis.rating_results
    .post_screening``, the report's thresholds) would leave out of a report written now:
    it screens the participants the report would otherwise include (not a pilot, nothing in
    ``excluded``), from ``rows`` (participant id, condition id, score, response time, trial
    kind) with ``reference`` the hidden reference's condition id. Returns ``{"rule",
    "screened": how many it screened, "excluded": {label: why}}``."""
    included = {
        row.id: row.label
        for row in participant_table(study, dropped_after=dropped_after)
        if not row.pilot and not row.excluded
    }
    mine = [r for r in rows if r[0] in included]
    frame = pd.DataFrame(
        {
            "participant": [included[r[0]] for r in mine],
            "score": [r[2] for r in mine],
            "reference": [r[1] == reference for r in mine],
            "kind": [r[4] for r in mine],
            "excluded": "",
        }
    )
    return {
        "rule": screening_rule(REFERENCE_BELOW, REFERENCE_SHARE),
        "screened": int(frame["participant"].nunique()),
        "excluded": post_screening(frame) if not frame.empty else {},
    }
