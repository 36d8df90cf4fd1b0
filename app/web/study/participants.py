"""The participants of a study as the experimenter manages them: status, quality at a glance,
exclusion (by hand or by the study's automatic rules), undoing an exclusion, and pilot
participants.

A participant's status is one of :data:`STATUSES` (``app.trials.participation``'s one
vocabulary, given by :func:`status_of` to the monitor, every export and the report):
``in_progress``, ``finished``, ``screened_out`` (the attention stop rule ended the session),
``dropped`` (unfinished and idle past the deployment's limit, or released), ``excluded`` (by the
experimenter, with a reason) or ``returned`` (gave the Prolific submission back, with an
optional note). Whether a participant's votes enter the analysis is a separate question,
answered by :func:`exclusion_reason`: pilot participants, excluded, returned and screened-out
ones, and those caught by the study's automatic rules (:data:`AUTO_RULES`, set by the study
file's ``auto_exclude``) are left out, each with the reason the report prints.

A participant whose browser plays none of the clips' renditions (no H.264, and no WebM/VP9 or
none offered) is excluded by the study itself, with that reason (:func:`end_for_browser`): the
page reports it, and the session ends there.

An excluded or returned participant gives their list slot back
(``app.web.study.enrolment.move_slot``), so the next arrival fills the gap in the
counterbalancing, and so does a participant who finishes having failed a catch trial (under
the ``catch_failed`` rule); pilot participants give theirs back when recruitment opens. Undoing
an exclusion (:func:`restore`) takes a finished participant's slot again; an unfinished one
takes it at their next request, as any participant back from a pause does.
"""

from __future__ import annotations

import datetime as dt
import statistics
from dataclasses import dataclass
from functools import cache
from typing import Any, NamedTuple

import sqlalchemy as sa

from app.trials.design import RATING_DESIGNS
from app.trials.participation import PARTICIPANT_STATUSES, SCREENED_OUT_REASON
from app.trials.questions import AUTO_EXCLUDE_RULES
from app.trials.rating import catch_ceiling
from app.web.extensions import db
from app.web.models import Participant, Rating, Study, StudyList, Trial, Vote, utcnow
from app.web.study.audiocheck import result as audio_result
from app.web.study.enrolment import move_slot
from app.web.study.labels import participant_label
from app.web.study.studies import rating_scale

STATUSES = tuple(PARTICIPANT_STATUSES)
#: How a participant is taken out by hand: the status it gives.
REMOVALS = ("excluded", "returned")
#: Rules the report applies by itself (the study file's ``auto_exclude`` chooses among them),
#: with the reason the report prints.
AUTO_RULES = dict(
    zip(
        AUTO_EXCLUDE_RULES,
        ("failed a catch trial", "did not finish", "failed the audio check"),
        strict=True,
    )
)


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
    #: The audio check's verdict: "passed", "failed", or "" (none taken or none decided).
    audio_check: str = ""


def status_of(participant: Participant, *, now: dt.datetime, dropped_after: dt.timedelta) -> str:
    """The participant's status (one of :data:`STATUSES`): the one answer every page and
    export gives. ``participant`` is a row or an object with the participant's columns."""
    if participant.excluded_at is not None:
        return participant.exclusion_kind if participant.exclusion_kind in REMOVALS else "excluded"
    if participant.finished_at is not None:
        return "finished"
    if participant.screened_out_at is not None:
        return "screened_out"
    if participant.dropped_at is not None or now - participant.last_seen_at > dropped_after:
        return "dropped"
    return "in_progress"


#: What the report says of a participant who returned their Prolific submission.
RETURNED = PARTICIPANT_STATUSES["returned"]


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
    if row.status == "returned":
        return f"{RETURNED}: {row.reason}" if row.reason else RETURNED
    if row.status == "excluded":
        return f"excluded: {row.reason}"
    if row.status == "screened_out":
        return SCREENED_OUT_REASON
    if "unfinished" in rules and row.status != "finished":
        return AUTO_RULES["unfinished"]
    if "catch_failed" in rules and row.catch_passed < row.catch_total:
        return f"{AUTO_RULES['catch_failed']} ({row.catch_passed} of {row.catch_total} passed)"
    if "audio_check_failed" in rules and row.audio_check == "failed":
        return AUTO_RULES["audio_check_failed"]
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
            audio_check=str(audio_result(person)["audio_check"]),
        )
        row.excluded = exclusion_reason(row, rules)
        out.append(row)
    return out


def remove(participant: Participant, *, how: str, reason: str) -> None:
    """Exclude ``participant`` (``how`` = "excluded", with ``reason``) or record that they
    returned their submission (``how`` = "returned", ``reason`` an optional note, kept); their
    list slot goes back. Not committed."""
    if how not in REMOVALS:
        raise ValueError(f"expected one of {', '.join(REMOVALS)}, got {how!r}")
    reason = " ".join(reason.split())
    if how == "excluded" and not reason:
        raise ValueError("give a reason for the exclusion")
    participant.excluded_at = utcnow()
    participant.exclusion_kind = how
    participant.exclusion_reason = reason[:300]
    _give_back_slot(participant)


#: ``exclusion_kind`` of a participant whose browser played none of the clips' renditions.
BROWSER = "browser"


def browser_reason(webm_offered: bool) -> str:
    """Why a participant whose browser played no rendition is left out: which renditions the
    page offered (a study rendered before renditions offered the MP4 alone)."""
    if webm_offered:
        return "browser cannot play the clips (no H.264 or WebM/VP9)"
    return "browser cannot play the clips (no H.264; no WebM offered)"


def end_for_browser(participant: Participant, *, webm_offered: bool) -> bool:
    """End the session of ``participant``, whose browser could play none of the renditions
    offered: excluded (kind :data:`BROWSER`, :func:`browser_reason`), the list slot given back
    at once rather than after the idle limit. False, and nothing changed, when they are
    already out. Not committed."""
    if participant.excluded_at is not None:
        return False
    participant.excluded_at = utcnow()
    participant.exclusion_kind = BROWSER
    participant.exclusion_reason = browser_reason(webm_offered)
    _give_back_slot(participant)
    return True


def ended_by_browser(participant: Participant) -> bool:
    """Whether the participant's session ended because their browser played no clip."""
    return participant.excluded_at is not None and participant.exclusion_kind == BROWSER


def restore(participant: Participant) -> None:
    """Undo :func:`remove`: the participant counts again as their other columns say. A
    finished participant takes their list slot back at once (unless the report leaves them
    out for a failed catch trial, or they are a pilot); an unfinished one takes it back at
    their next request (``app.web.study.enrolment.touch``). Not committed."""
    if participant.excluded_at is None:
        raise ValueError("is not excluded")
    participant.excluded_at = None
    participant.exclusion_kind = ""
    participant.exclusion_reason = ""
    db.session.flush()
    if participant.finished_at is None or participant.pilot:
        return
    if left_out(participant.study, participant.id, pilot=participant.pilot):
        return
    retaken = db.session.execute(
        sa.update(Participant)
        .where(Participant.id == participant.id, Participant.dropped_at.is_not(None))
        .values(dropped_at=None)
        .execution_options(synchronize_session=False)
    )
    if retaken.rowcount == 1:
        move_slot(participant.list_id, +1)
    db.session.refresh(participant)


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
