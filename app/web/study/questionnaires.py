"""A study's questionnaire pages on the web: which page a participant still owes, storing the
answers, the answers export (one row per participant, joined to the votes by the participant
label) and the summary the report prints.

The questions are the study file's (``app.trials.questions``), kept in the study's settings as
study-file tables, so a study reads back exactly what its file said.
"""

from __future__ import annotations

import statistics
from collections import Counter
from pathlib import Path
from typing import Any

import sqlalchemy as sa

from app.trials.questions import PAGES, ExperimenterSideReader, QuestionSpec
from app.web.extensions import db
from app.web.models import Participant, Study
from app.web.study.csvcells import csv_text
from app.web.study.enrolment import dropped_after
from app.web.study.labels import participant_label, pseudonym
from app.web.study.participants import participant_table


def study_questions(study: Study, page: str | None = None) -> list[QuestionSpec]:
    """The study's questions (of one page, or all), in file order."""

    tables = (study.settings or {}).get("questions") or []
    reader = ExperimenterSideReader("study", Path("."))  # questions name no files
    questions = [reader.question(t, f"questions[{i}]") for i, t in enumerate(tables)]
    return [q for q in questions if page is None or q.page == page]


def pending_page(participant: Participant) -> str | None:
    """The questionnaire page ``participant`` must fill in now: ``before`` until answered,
    ``after`` once every vote is in; None when nothing is owed."""
    answered = participant.answers or {}
    for page in PAGES:
        if page in answered or not study_questions(participant.study, page):
            continue
        if page == "before" or participant.finished_at is not None:
            return page
    return None


def save_answers(participant: Participant, page: str, values: dict[str, Any]) -> None:
    """Store a page's checked answers (not committed); a page is answered once."""
    answers = dict(participant.answers or {})
    answers.setdefault(page, values)
    participant.answers = answers  # a new dict, so the JSON column is written


def answers_csv(study: Study, *, pilot: bool = False) -> str:
    """One row per participant who answered anything: label, status, pseudonymised Prolific
    ID, then one column per question (the ``participant`` column joins it to the votes)."""

    questions = study_questions(study)
    rows = {
        r.id: r for r in participant_table(study, dropped_after=dropped_after()) if r.pilot == pilot
    }
    header = ["participant", "status", "excluded", "prolific_id", *(q.name for q in questions)]
    lines: list[list[Any]] = []
    people = db.session.scalars(
        sa.select(Participant).where(Participant.study_id == study.id).order_by(Participant.number)
    )
    for person in people:
        if person.id not in rows or not person.answers:
            continue
        given = {k: v for page in person.answers.values() for k, v in page.items()}
        row = rows[person.id]
        lines.append(
            [
                row.label,
                row.status,
                row.excluded,
                pseudonym(study.pseudonym_key, person.prolific_pid),
                *(_cell(given.get(q.name)) for q in questions),
            ]
        )
    return csv_text(header, lines)


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    return str(value)


def answers_summary(study: Study, included: set[str] | None = None) -> list[dict[str, Any]]:
    """Per question, what the participants (those labelled in ``included``, or all but pilots)
    answered: counts per option, median and range of numbers, the texts."""

    people = db.session.scalars(
        sa.select(Participant).where(Participant.study_id == study.id, Participant.pilot.is_(False))
    )
    given: list[dict[str, Any]] = []
    for person in people:
        if included is not None and participant_label(person.number) not in included:
            continue
        given.append({k: v for page in (person.answers or {}).values() for k, v in page.items()})
    out = []
    for q in study_questions(study):
        values = [g[q.name] for g in given if g.get(q.name) is not None]
        entry: dict[str, Any] = {
            "name": q.name,
            "text": q.text,
            "kind": q.kind,
            "answered": len(values),
            "asked": len(given),
        }
        if q.kind == "choice":
            counts = Counter(values)
            entry["counts"] = {c: counts.get(c, 0) for c in q.choices}
        elif q.kind == "number" and values:
            entry |= {"median": statistics.median(values), "min": min(values), "max": max(values)}
        elif q.kind == "text":
            entry["texts"] = [str(v) for v in values]
        out.append(entry)
    return out
