"""Participants' personal data: the participants export, pseudonymised by default, and
deleting one participant's data on request.

The only personal data stored are Prolific's ``PROLIFIC_PID`` and ``SESSION_ID`` (and the
browser's user agent, never exported). An export shared for analysis carries a pseudonym in
their place: ``anon-`` and the first 16 hex digits of HMAC-SHA256 over the ID, keyed with the
study's own random ``pseudonym_key``. The same person keeps the same pseudonym across exports of
a study, but nobody without the database can tell who it is, and pseudonyms of two studies
cannot be linked. The raw IDs are exported only when asked for (to pay participants).
"""

from __future__ import annotations

import re
import shutil
from dataclasses import dataclass
from typing import Any

import sqlalchemy as sa

from app.trials.design import RATING_DESIGNS
from app.trials.rating import catch_ceiling
from app.trials.rules import CHOICES
from app.web.extensions import db
from app.web.infra import media
from app.web.infra.storage import report_path
from app.web.models import Participant, Rating, Stimulus, Study, Trial, Vote
from app.web.study.audiocheck import result as audio_result
from app.web.study.csvcells import csv_text
from app.web.study.enrolment import dropped_after, move_slot
from app.web.study.labels import iso_time, participant_label, pseudonym
from app.web.study.participants import participant_table
from app.web.study.studies import rating_scale

#: Columns of the participants export, in order.
PARTICIPANT_COLUMNS = (
    "participant",
    "prolific_pid",
    "prolific_study_id",
    "prolific_session_id",
    "status",
    "pilot",
    "excluded",
    # Trials answered (the practice never counts): votes, or in the rating designs the trials
    # rated (a parallel page rates every version of its clip and is one trial).
    "answered",
    # Catch trials (attention checks) answered as expected, and answered; a rating check is
    # passed at the bottom of the scale (app.trials.rating.catch_ceiling).
    "catch_passed",
    "catch_total",
    "consented_at",
    "started_at",
    "finished_at",
    "identical_left",
    "identical_right",
    "identical_undecided",
    "browser",
    "screen",
    "viewport",
    "dpr",
    "touch",
    "face_px",
    # The audio check (app.web.study.audiocheck): verdict, attempts, last attempt's score.
    "audio_check",
    "audio_check_attempts",
    "audio_check_score",
)
#: Columns holding personal identifiers: pseudonymised unless the raw IDs are asked for.
PERSONAL_COLUMNS = ("prolific_pid", "prolific_session_id")


def participants_export_rows(study: Study, *, raw_ids: bool = False) -> list[dict[str, Any]]:
    """One dict per participant of ``study`` (columns :data:`PARTICIPANT_COLUMNS`), ordered by
    arrival; Prolific IDs pseudonymised unless ``raw_ids``."""
    counts = _rating_tallies(study) if study.design in RATING_DESIGNS else _vote_tallies(study)
    # status and the analysis's reason as the monitor and the votes export give them
    table = {row.id: row for row in participant_table(study, dropped_after=dropped_after())}
    rows = []
    for person in db.session.scalars(
        sa.select(Participant).where(Participant.study_id == study.id).order_by(Participant.number)
    ):
        tally = counts.get(person.id, {})
        env = person.environment or {}
        row = {
            "participant": participant_label(person.number),
            "prolific_pid": person.prolific_pid or "",
            "prolific_study_id": person.prolific_study_id or "",
            "prolific_session_id": person.prolific_session_id or "",
            "status": table[person.id].status,
            "pilot": "true" if person.pilot else "false",
            "excluded": table[person.id].excluded,
            "answered": tally.get("answered", 0),
            "catch_passed": tally.get("catch_passed", 0),
            "catch_total": tally.get("catch_total", 0),
            "consented_at": iso_time(person.consented_at),
            "started_at": iso_time(person.started_at),
            "finished_at": iso_time(person.finished_at),
            **{f"identical_{c}": tally.get(f"identical_{c}", 0) for c in CHOICES},
            "browser": " ".join(filter(None, (env.get("browser"), env.get("browser_version")))),
            "screen": _size(env, "screen"),
            "viewport": _size(env, "viewport"),
            "dpr": env.get("dpr", ""),
            "touch": env.get("touch", ""),
            "face_px": env.get("face_px", ""),
            **audio_result(person),
        }
        if not raw_ids:
            for column in PERSONAL_COLUMNS:
                row[column] = pseudonym(study.pseudonym_key, row[column])
        rows.append(row)
    return rows


def _vote_tallies(study: Study) -> dict[int, dict[str, int]]:
    """Per participant id of a pair study: votes (``answered``), catch trials answered as
    expected and answered, and the identical pairs' answers by choice."""
    catch_total = sa.func.count(sa.case((Trial.kind == "catch", Vote.id)))
    catch_passed = sa.func.count(
        sa.case((sa.and_(Trial.kind == "catch", Vote.choice == Trial.expected), Vote.id))
    )
    same = sa.and_(Stimulus.left_id == Stimulus.right_id, Trial.kind != "mismatch")
    # Pairs without a difference measure the side bias: an unbiased participant answers
    # undecided, or left and right about equally often.
    identical = {
        choice: sa.func.count(sa.case((sa.and_(same, Vote.choice == choice), Vote.id))).label(
            f"identical_{choice}"
        )
        for choice in CHOICES
    }
    rows = db.session.execute(
        sa.select(
            Vote.participant_id,
            sa.func.count(Vote.id).label("answered"),
            catch_total.label("catch_total"),
            catch_passed.label("catch_passed"),
            *identical.values(),
        )
        .join(Trial, Vote.trial_id == Trial.id)
        .join(Stimulus, Trial.stimulus_id == Stimulus.id)
        .join(Participant, Vote.participant_id == Participant.id)
        .where(Participant.study_id == study.id)
        .group_by(Vote.participant_id)
    )
    return {row.participant_id: dict(row._mapping) for row in rows}


def _rating_tallies(study: Study) -> dict[int, dict[str, int]]:
    """Per participant id of a rating or parallel study: the trials rated (``answered``; a
    parallel trial holds one rating per version, and counts once, as the participant's
    progress counts it: ``app.web.study.progress.progress_counts``), and the checks rated at
    the bottom of the scale and rated."""
    ceiling = catch_ceiling(rating_scale(study))
    check = Trial.kind == "catch"
    rows = db.session.execute(
        sa.select(
            Rating.participant_id,
            sa.func.count(sa.distinct(Rating.trial_id)).label("answered"),
            sa.func.count(sa.distinct(sa.case((check, Rating.trial_id)))).label("catch_total"),
            sa.func.count(
                sa.distinct(sa.case((sa.and_(check, Rating.score <= ceiling), Rating.trial_id)))
            ).label("catch_passed"),
        )
        .join(Trial, Rating.trial_id == Trial.id)
        .join(Participant, Rating.participant_id == Participant.id)
        .where(Participant.study_id == study.id)
        .group_by(Rating.participant_id)
    )
    return {row.participant_id: dict(row._mapping) for row in rows}


def _size(environment: dict[str, Any], name: str) -> str:
    width, height = environment.get(f"{name}_w"), environment.get(f"{name}_h")
    return f"{width}x{height}" if width and height else ""


def participants_csv(study: Study, *, raw_ids: bool = False) -> str:
    """:func:`participants_export_rows` as CSV text with a header row."""
    rows = participants_export_rows(study, raw_ids=raw_ids)
    return csv_text(
        PARTICIPANT_COLUMNS, ([row.get(name, "") for name in PARTICIPANT_COLUMNS] for row in rows)
    )


@dataclass(frozen=True)
class Deleted:
    """What a deletion removed: the participants' export labels, their votes and (in the
    rating designs) ratings."""

    labels: tuple[str, ...]
    votes: int
    ratings: int = 0


def find_participants(study: Study, identifier: str) -> list[Participant]:
    """The participants of ``study`` that ``identifier`` names: an export label (``P0007``),
    a raw Prolific ID or its pseudonym (a person who joined twice is found twice)."""
    identifier = identifier.strip()
    if not identifier:
        return []
    people = db.session.scalars(
        sa.select(Participant).where(Participant.study_id == study.id).order_by(Participant.number)
    ).all()
    label = re.fullmatch(r"[Pp]0*(\d{1,9})", identifier)
    return [
        p
        for p in people
        if (label is not None and p.number == int(label.group(1)))
        or (
            p.prolific_pid
            and identifier in (p.prolific_pid, pseudonym(study.pseudonym_key, p.prolific_pid))
        )
    ]


def delete_participants(study: Study, identifier: str) -> Deleted:
    """Delete every trace of the participants ``identifier`` names (:func:`find_participants`):
    their votes or ratings, schedule and row. A participant still holding a list slot gives it
    back, so balancing continues over the others. The study's report, which was computed with
    their answers, is removed (the caller writes a new one). Not committed."""
    people = find_participants(study, identifier)
    if not people:
        return Deleted((), 0)
    ids = [p.id for p in people]
    labels = tuple(participant_label(p.number) for p in people)
    holding = [p.list_id for p in people if p.dropped_at is None]
    votes = db.session.execute(
        sa.delete(Vote)
        .where(Vote.participant_id.in_(ids))
        .execution_options(synchronize_session=False)
    ).rowcount
    ratings = db.session.execute(
        sa.delete(Rating)
        .where(Rating.participant_id.in_(ids))
        .execution_options(synchronize_session=False)
    ).rowcount
    db.session.execute(
        sa.delete(Trial)
        .where(Trial.participant_id.in_(ids))
        .execution_options(synchronize_session=False)
    )
    for list_id in holding:
        move_slot(list_id, -1)
    db.session.execute(
        sa.delete(Participant)
        .where(Participant.id.in_(ids))
        .execution_options(synchronize_session=False)
    )
    db.session.expire_all()
    folder = report_path(study).parent
    media.forget(study, folder.name)  # the report's votes.csv names them
    shutil.rmtree(folder, ignore_errors=True)
    study.report_at = None
    return Deleted(labels, int(votes or 0), int(ratings or 0))
