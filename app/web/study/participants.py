"""The participants of a study as the experimenter manages them: status, quality at a glance,
exclusion (by hand or by the study's automatic rules) and pilot participants.

A participant's status is one of :data:`STATUSES`: ``started`` (taking part), ``finished``,
``dropped`` (unfinished and idle past the deployment's limit, or released), ``excluded`` (by
the experimenter, with a reason) or ``returned`` (gave the Prolific submission back). Whether a
participant's votes enter the analysis is a separate question, answered by
:func:`exclusion_reason`: pilot participants, excluded and returned ones, and those caught by
the study's automatic rules (:data:`AUTO_RULES`, set by the study file's ``auto_exclude``) are
left out, each with the reason the report prints.

An excluded or returned participant gives their list slot back
(``app.web.study.enrolment.move_slot``), so the next arrival fills the gap in the
counterbalancing, and so does a participant who finishes having failed a catch trial (under
the ``catch_failed`` rule); pilot participants give theirs back when recruitment opens.
"""

from __future__ import annotations

import datetime as dt
import statistics
from dataclasses import dataclass
from functools import cache
from typing import Any, NamedTuple

import sqlalchemy as sa

from app.trials.design import RATING_DESIGNS
from app.trials.questions import AUTO_EXCLUDE_RULES
from app.trials.rating import catch_ceiling
from app.web.extensions import db
from app.web.models import Participant, Rating, Study, StudyList, Trial, Vote, utcnow
from app.web.study.enrolment import move_slot
from app.web.study.labels import participant_label
from app.web.study.studies import rating_scale

STATUSES = ("started", "finished", "dropped", "excluded", "returned")
#: How a participant is taken out by hand: the status it gives.
REMOVALS = ("excluded", "returned")
#: Rules the report applies by itself (the study file's ``auto_exclude`` chooses among them),
#: with the reason the report prints.
AUTO_RULES = dict(zip(AUTO_EXCLUDE_RULES, ("failed a catch trial", "did not finish"), strict=True))


@dataclass
class ParticipantRow:
    """One line of the monitor's participant table (and of the votes export's status)."""

    id: int
    label: str
    prolific_pid: str | None
    status: str
    list_index: int
    pilot: bool
    catch_passed: int
    catch_total: int
    #: Share of "left" among the decided answers of real trials (0.5: no side bias).
    left_share: float | None
    median_ms: float | None
    started_at: dt.datetime | None
    finished_at: dt.datetime | None
    reason: str
    #: Why the analysis leaves this participant out ("" when included).
    excluded: str = ""


def status_of(participant: Participant, *, now: dt.datetime, dropped_after: dt.timedelta) -> str:
    """The participant's status (one of :data:`STATUSES`)."""
    if participant.excluded_at is not None:
        return "returned" if participant.exclusion_reason == RETURNED else "excluded"
    if participant.finished_at is not None:
        return "finished"
    if participant.dropped_at is not None or now - participant.last_seen_at > dropped_after:
        return "dropped"
    return "started"


#: The reason stored for a participant who returned their Prolific submission.
RETURNED = "returned the submission on Prolific"


def auto_rules(study: Study) -> tuple[str, ...]:
    """The automatic exclusion rules of ``study`` (the study file's ``auto_exclude``)."""
    rules = (study.settings or {}).get("auto_exclude")
    return tuple(AUTO_RULES) if rules is None else tuple(rules)


def exclusion_reason(row: ParticipantRow, rules: tuple[str, ...]) -> str:
    """Why the analysis leaves ``row`` out, or "" if it counts.

    >>> row = ParticipantRow(1, "P0001", None, "finished", 0, False, 1, 2, .5, 900., None,
    ...                      None, "")
    >>> exclusion_reason(row, ("catch_failed",)), exclusion_reason(row, ())
    ('failed a catch trial (1 of 2 passed)', '')
    """
    if row.pilot:
        return "pilot"
    if row.status in REMOVALS:
        return row.reason if row.status == "returned" else f"excluded: {row.reason}"
    if "unfinished" in rules and row.status != "finished":
        return AUTO_RULES["unfinished"]
    if "catch_failed" in rules and row.catch_passed < row.catch_total:
        return f"{AUTO_RULES['catch_failed']} ({row.catch_passed} of {row.catch_total} passed)"
    return ""


class _Answer(NamedTuple):
    """A rating read as the vote columns :func:`participant_table` looks at."""

    participant_id: int
    choice: str
    response_ms: int | None
    kind: str
    expected: str


def participant_table(study: Study, *, dropped_after: dt.timedelta) -> list[ParticipantRow]:
    """Every participant of ``study`` (pilots included) in arrival order, with their catch
    score, side bias and median response time from their votes."""

    now = utcnow()
    rules = auto_rules(study)
    people = db.session.execute(
        sa.select(Participant, StudyList.index)
        .join(StudyList)
        .where(Participant.study_id == study.id)
        .order_by(Participant.number)
    ).all()
    votes: dict[int, list[Any]] = {}
    for row in db.session.execute(
        sa.select(Vote.participant_id, Vote.choice, Vote.response_ms, Trial.kind, Trial.expected)
        .join(Trial, Vote.trial_id == Trial.id)
        .join(Participant, Vote.participant_id == Participant.id)
        .where(Participant.study_id == study.id)
    ):
        votes.setdefault(row.participant_id, []).append(row)
    if study.design in RATING_DESIGNS:
        # a rating check is passed by a score at the bottom of the scale: read as a vote that
        # chose the expected answer or not
        ceiling = catch_ceiling(rating_scale(study))
        for row in db.session.execute(
            sa.select(Rating.participant_id, Rating.score, Rating.response_ms, Trial.kind)
            .join(Trial, Rating.trial_id == Trial.id)
            .join(Participant, Rating.participant_id == Participant.id)
            .where(Participant.study_id == study.id)
        ):
            # no side to prefer ("undecided"); a check passed chooses the expected answer
            choice = "pass" if row.kind == "catch" and row.score <= ceiling else "undecided"
            votes.setdefault(row.participant_id, []).append(
                _Answer(row.participant_id, choice, row.response_ms, row.kind, "pass")
            )
    out = []
    for person, list_index in people:
        mine = votes.get(person.id, [])
        catch = [v for v in mine if v.kind == "catch"]
        decided = [v.choice for v in mine if v.kind == "trial" and v.choice != "undecided"]
        times = [v.response_ms for v in mine if v.response_ms is not None]
        row = ParticipantRow(
            id=person.id,
            label=participant_label(person.number),
            prolific_pid=person.prolific_pid,
            status=status_of(person, now=now, dropped_after=dropped_after),
            list_index=list_index,
            pilot=person.pilot,
            catch_passed=sum(v.choice == v.expected for v in catch),
            catch_total=len(catch),
            left_share=decided.count("left") / len(decided) if decided else None,
            median_ms=statistics.median(times) if times else None,
            started_at=person.started_at,
            finished_at=person.finished_at,
            reason=person.exclusion_reason,
        )
        row.excluded = exclusion_reason(row, rules)
        out.append(row)
    return out


def remove(participant: Participant, *, how: str, reason: str) -> None:
    """Exclude ``participant`` (``how`` = "excluded", with ``reason``) or record that they
    returned their submission (``how`` = "returned"); their list slot goes back. Not
    committed."""
    if how not in REMOVALS:
        raise ValueError(f"expected one of {', '.join(REMOVALS)}, got {how!r}")
    reason = RETURNED if how == "returned" else reason.strip()
    if not reason:
        raise ValueError("give a reason for the exclusion")
    participant.excluded_at = utcnow()
    participant.exclusion_reason = reason[:300]
    _give_back_slot(participant)


def _give_back_slot(participant: Participant) -> None:
    """Release the participant's list slot once (a participant holds one while ``dropped_at``
    is empty, see ``app.web.study.enrolment.touch``)."""
    released = db.session.execute(
        sa.update(Participant)
        .where(Participant.id == participant.id, Participant.dropped_at.is_(None))
        .values(dropped_at=utcnow())
        .execution_options(synchronize_session=False)
    )
    if released.rowcount == 1:
        move_slot(participant.list_id, -1)
    db.session.refresh(participant)


def may_be_left_out(study: Any, *, pilot: bool) -> bool:
    """Whether a finished participant of ``study`` could be left out of the report for a
    failed catch trial at all (the study's ``catch_failed`` rule, never a pilot): when not,
    :func:`left_out` is False without asking the database."""
    return not pilot and "catch_failed" in auto_rules(study)


def left_out(study: Any, participant_id: int, *, pilot: bool) -> bool:
    """Whether the report leaves a finished participant out for a failed catch trial (the
    study's ``catch_failed`` rule); ``study`` is a row or an ORM object with ``settings``."""
    if not may_be_left_out(study, pilot=pilot):
        return False
    if study.design in RATING_DESIGNS:
        ceiling = catch_ceiling(rating_scale(study))
        failed = db.session.scalar(
            failed_rating_check(), {"participant_id": participant_id, "ceiling": ceiling}
        )
    else:
        failed = db.session.scalar(failed_catch(), {"participant_id": participant_id})
    return failed is not None


@cache
def failed_rating_check() -> sa.Select[tuple[int]]:
    """A rating of the bound ``participant_id`` that failed an instructed check: above the
    bound ``ceiling`` (:func:`app.trials.rating.catch_ceiling`); at most one row."""
    return (
        sa.select(Rating.id)
        .join(Trial, Rating.trial_id == Trial.id)
        .where(
            Rating.participant_id == sa.bindparam("participant_id"),
            Trial.kind == "catch",
            Rating.score > sa.bindparam("ceiling", type_=sa.Integer),
        )
        .limit(1)
    )


@cache
def failed_catch() -> sa.Select[tuple[int]]:
    """A vote of the bound ``participant_id`` that failed a catch trial (at most one row): the
    question :func:`left_out` asks, built once."""
    return (
        sa.select(Vote.id)
        .join(Trial, Vote.trial_id == Trial.id)
        .where(
            Vote.participant_id == sa.bindparam("participant_id"),
            Trial.kind == "catch",
            Vote.choice != Trial.expected,
        )
        .limit(1)
    )


def release_if_left_out(participant: Participant) -> bool:
    """A participant who has just finished but failed a catch trial, under the study's
    ``catch_failed`` rule, gives the list slot back: the report leaves them out, so the lists
    stay balanced over the participants it counts. Not committed; True if released."""
    if not left_out(participant.study, participant.id, pilot=participant.pilot):
        return False
    _give_back_slot(participant)
    return True


def release_pilots(study: Study) -> int:
    """Give back the list slots of ``study``'s pilot participants (recruitment opens: the real
    participants are balanced among themselves). Not committed."""
    pilots = db.session.scalars(
        sa.select(Participant).where(
            Participant.study_id == study.id,
            Participant.pilot.is_(True),
            Participant.dropped_at.is_(None),
        )
    ).all()
    for pilot in pilots:
        _give_back_slot(pilot)
    return len(pilots)
