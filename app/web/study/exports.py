"""Votes in the analysis module's CSV schema, and the analysis report of a study.

The column names come from ``app.analysis.votes.VOTE_COLUMNS`` (one place for the votes
schema), with the media log and the answer details of each vote. Practice answers are never
stored; catch trials (attention checks) are exported with ``kind = catch`` and the analysis
leaves them out; appropriateness pairs are exported with their ``mismatched`` side and analysed
on their own (``app.analysis.appropriateness``). Every row carries its participant's status,
pseudonymised Prolific ID and, when the analysis is to leave them out, why
(``app.web.study.participants``). Pilot participants are exported only when asked for
(``pilot="with"`` or ``"only"``).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import io
import json
import shlex
from pathlib import Path
from typing import Any

import pandas as pd
import sqlalchemy as sa

from app.analysis.package import RESULTS
from app.analysis.rating_results import (
    NO_RATINGS,
    REFERENCE_BELOW,
    REFERENCE_SHARE,
    analyze_ratings,
    post_screening,
    ratings_text,
    read_ratings,
    screening_rule,
)
from app.analysis.results import analyze
from app.analysis.votes import VOTE_COLUMNS, VotesTable, read_votes, write_votes_csv
from app.errors import InputError
from app.trials.design import RATING_DESIGNS
from app.trials.rating import parallel_order
from app.web.extensions import db
from app.web.infra.storage import report_path
from app.web.models import Clip, Condition, Participant, Rating, Stimulus, Study, Trial, Vote
from app.web.study.csvcells import safe_csv
from app.web.study.enrolment import dropped_after
from app.web.study.labels import iso_time, participant_label, pseudonym
from app.web.study.participants import participant_table
from app.web.study.questionnaires import answers_summary
from app.web.study.studies import rating_scale


def _people(study: Study, pilot: str) -> dict[int, Any]:
    """The participants whose answers an export holds, by id (:func:`vote_rows`' ``pilot``)."""
    return {
        row.id: row
        for row in participant_table(study, dropped_after=dropped_after())
        if (pilot == "with") or (row.pilot == (pilot == "only"))
    }


def vote_rows(study: Study, *, pilot: str = "without") -> list[dict[str, Any]]:
    """One dict per stored vote of a real or catch trial, ordered by participant and trial
    position; ``pilot`` is "without" (default), "with" or "only" the pilot participants."""

    people = _people(study, pilot)
    left = sa.orm.aliased(Condition)
    right = sa.orm.aliased(Condition)
    query = (
        sa.select(
            Vote,
            Trial.position,
            Trial.kind,
            Participant.id,
            Participant.number,
            Participant.prolific_pid,
            Clip.name,
            left.name,
            right.name,
            Stimulus.foreign_side,
        )
        .join(Trial, Vote.trial_id == Trial.id)
        .join(Participant, Vote.participant_id == Participant.id)
        .join(Stimulus, Trial.stimulus_id == Stimulus.id)
        .join(Clip, Stimulus.clip_id == Clip.id)
        .join(left, Stimulus.left_id == left.id)
        .join(right, Stimulus.right_id == right.id)
        .where(Participant.study_id == study.id, Trial.kind.in_(("trial", "mismatch", "catch")))
        .order_by(Participant.number, Trial.position)
    )
    rows = []
    for (
        vote,
        position,
        kind,
        person,
        number,
        pid,
        clip,
        left_name,
        right_name,
        foreign,
    ) in db.session.execute(query):
        if person not in people:
            continue
        rows.append(
            {
                "participant": participant_label(number),
                "clip": clip,
                "left": left_name,
                "right": right_name,
                "choice": vote.choice,
                "study": study.title,
                "trial": position,
                "response_ms": vote.response_ms,
                "plays": vote.plays,
                "presented_at": iso_time(vote.presented_at),
                "voted_at": iso_time(vote.voted_at),
                "strength": vote.strength,
                "reasons": ";".join(vote.reasons or []),
                "mismatched": foreign,
                "watched_ms": vote.watched_ms,
                "played_to_end": vote.played_to_end,
                "stalls": vote.stalls,
                "stall_ms": vote.stall_ms,
                "focus_lost": vote.focus_lost,
                "kind": kind,
                "status": people[person].status,
                "excluded": people[person].excluded,
                "prolific_id": pseudonym(study.pseudonym_key, pid),
            }
        )
    return rows


def rating_rows(study: Study, *, pilot: str = "without") -> list[dict[str, Any]]:
    """One dict per stored rating (``app.analysis.rating_results.RATING_COLUMNS``), ordered
    by participant and trial position; ``pilot`` as for :func:`vote_rows`. In the
    ``parallel`` design ``screened`` says why the hidden-reference post-screening leaves a
    participant out (``app.analysis.rating_results.post_screening`` on these rows, as the
    analysis decides it again from the file)."""
    people = _people(study, pilot)
    scale = rating_scale(study)
    query = (
        sa.select(
            Rating,
            Trial.position,
            Trial.kind,
            Participant.id,
            Participant.number,
            Participant.prolific_pid,
            Participant.seed,
            Clip.name,
            Condition.name,
        )
        .join(Trial, Rating.trial_id == Trial.id)
        .join(Participant, Rating.participant_id == Participant.id)
        .join(Stimulus, Trial.stimulus_id == Stimulus.id)
        .join(Clip, Stimulus.clip_id == Clip.id)
        .join(Condition, Rating.condition_id == Condition.id)
        .where(Participant.study_id == study.id)
        .order_by(Participant.number, Trial.position, Condition.position)
    )
    names = [c.name for c in study.conditions]
    rows = []
    for rating, position, kind, person, number, pid, seed, clip, condition in db.session.execute(
        query
    ):
        if person not in people:
            continue
        item = None
        if study.design == "parallel":  # the item's place on its page, and the hidden reference
            item = parallel_order(names, seed=seed, position=position).index(condition) + 1
        rows.append(
            {
                "participant": participant_label(number),
                "clip": clip,
                "condition": condition,
                "item": item,
                "reference": None if item is None else condition == study.reference,
                "score": rating.score,
                "scale": scale,
                "trial": position,
                "kind": kind,
                "response_ms": rating.response_ms,
                "plays": rating.plays,
                "presented_at": iso_time(rating.presented_at),
                "rated_at": iso_time(rating.rated_at),
                "watched_ms": rating.watched_ms,
                "played_to_end": rating.played_to_end,
                "stalls": rating.stalls,
                "stall_ms": rating.stall_ms,
                "focus_lost": rating.focus_lost,
                "status": people[person].status,
                "excluded": people[person].excluded,
                "screened": "",
                "prolific_id": pseudonym(study.pseudonym_key, pid),
                "study": study.title,
            }
        )
    if study.design == "parallel" and rows:
        screened = post_screening(pd.DataFrame(rows))
        for row in rows:
            row["screened"] = screened.get(row["participant"], "")
    return rows


def ratings_csv(study: Study, *, pilot: str = "without") -> str:
    """The study's ratings as CSV text (``app.analysis.rating_results.write_ratings_csv``),
    formula-like text cells neutralised as in :func:`votes_csv`."""
    return safe_csv(ratings_text(rating_rows(study, pilot=pilot)))


def votes_table(study: Study, *, pilot: str = "without") -> VotesTable:
    """The study's votes, validated once by the analysis reader's rules
    (``app.analysis.votes.read_votes``): what the CSV export writes and the report analyses."""
    rows = vote_rows(study, pilot=pilot)
    return read_votes(pd.DataFrame(rows) if rows else pd.DataFrame(columns=list(VOTE_COLUMNS)))


def votes_csv(study: Study, *, pilot: str = "without") -> str:
    """The study's votes as CSV text (``app.analysis.votes.write_votes_csv``), with text cells a
    spreadsheet would run as formulas neutralised (:func:`app.web.study.csvcells.safe_cell`)."""
    buffer = io.StringIO()
    write_votes_csv(votes_table(study, pilot=pilot), buffer)
    return safe_csv(buffer.getvalue())


def write_report_files(study: Study) -> Path:
    """Analyse the votes so far and write the report into the study's media folder: HTML,
    PDF and every number as JSON (``results.json``), headed by the study's title, design and
    participants. The votes analysed are those
    written beside them as CSV (which ``facepair analyze`` reads back to the same report)."""
    path = report_path(study)
    path.parent.mkdir(parents=True, exist_ok=True)
    if study.design in RATING_DESIGNS:
        return _write_rating_report(study, path)
    csv_path = path.parent / "votes.csv"
    # The report names the file it analysed by its place beside the report and in the study's
    # package (votes.csv), never by the server's folder.
    votes = dataclasses.replace(votes_table(study), source=csv_path.name)
    write_votes_csv(votes, csv_path)
    # exclusion rules as `facepair analyze --exclude` reads them (app.analysis.quality)
    exclude = study.settings.get("exclude")
    try:
        results = analyze(votes, conditions=[c.name for c in study.conditions], exclude=exclude)
    except InputError as exc:
        if exc.message != NO_VOTES:
            raise
        return _write_no_answers_page(study, path)
    results["study"] = report_head(study, results, exclude=exclude)
    return _write_analysis(results, path)


def _write_analysis(results: dict[str, Any], path: Path) -> Path:
    """The report at ``path``, its PDF beside it, and every number of it as ``results.json``
    (for the study's package, app.web.study.package)."""
    from app.analysis.report.writer import write_report  # matplotlib: only when a report is written

    write_report(results, path, path.with_suffix(".pdf"))
    (path.parent / RESULTS).write_text(
        json.dumps(results, indent=1, allow_nan=False) + "\n", encoding="utf-8"
    )
    return path


def _write_no_answers_page(
    study: Study, path: Path, *, screened: dict[str, str] | None = None
) -> Path:
    """The page saying there is nothing to analyse yet, in place of the report; an earlier
    report's PDF and numbers go, as they would contradict it. ``screened``: the participants
    the post-screening of a ``parallel`` study left out, with the reason."""
    path.with_suffix(".pdf").unlink(missing_ok=True)
    (path.parent / RESULTS).unlink(missing_ok=True)
    path.write_text(no_votes_page(study, screened=screened), encoding="utf-8")
    return path


def _write_rating_report(study: Study, path: Path) -> Path:
    """The rating design's report: ``ratings.csv`` written beside it and analysed as
    ``facepair analyze ratings.csv`` does (:func:`app.analysis.rating_results.analyze_ratings`)."""
    from app.analysis.report.blocks import counted

    csv_path = path.parent / "ratings.csv"
    csv_path.write_text(ratings_csv(study), encoding="utf-8")
    table = read_ratings(csv_path)
    try:
        results = analyze_ratings(
            table,
            conditions=[c.name for c in study.conditions],
            source=csv_path.name,
        )
    except InputError as exc:
        # the message goes on to say why, e.g. the post-screening left everyone out
        if not exc.message.startswith(NO_RATINGS):
            raise
        return _write_no_answers_page(study, path, screened=post_screening(table))
    included = results["input"]["participants"]
    left_out = results["input"]["left_out"]
    results["study"] = {
        "title": study.title,
        "design": f"Design: {study.design}"
        + (f" against the hidden reference {study.reference}" if study.reference else "")
        + f" ({rating_scale(study)}); conditions "
        f"{', '.join(c.name for c in study.conditions)}; clips "
        f"{', '.join(c.name for c in study.clips)}; question: {study.question!r}; "
        f"{study.catch_trials} attention checks per participant.",
        "participants": f"{counted(included, 'participant')} included, {len(left_out)} left out.",
        "date": dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "command": shlex.join(
            ["facepair", "analyze", "ratings.csv", "--report", "report.html", "--pdf", "report.pdf"]
        ),
        "votes_file": "ratings.csv",
    }
    return _write_analysis(results, path)


#: The analysis's message when no vote is left to analyse (``app.analysis.results.analyze``).
NO_VOTES = "no valid votes to analyse"


def no_votes_page(study: Study, *, screened: dict[str, str] | None = None) -> str:
    """The report page of a study without a vote (in the rating designs, a rating) from an
    included participant: it says so and who was left out (pilots, exclusions and, in the
    ``parallel`` design, the hidden-reference post-screening: ``screened``, each participant
    with the reason), in place of statistics and a PDF."""
    from flask import render_template

    from app.analysis.report.blocks import counted

    rows = participant_table(study, dropped_after=dropped_after())
    pilots = sum(row.pilot for row in rows)
    left_out = [(row.label, row.excluded) for row in rows if row.excluded and not row.pilot]
    screening = None
    by_screening = ""
    if study.design == "parallel":
        screened = screened or {}
        screening = {
            "rule": screening_rule(REFERENCE_BELOW, REFERENCE_SHARE),
            "count": counted(len(screened), "participant"),
            "left_out": sorted(screened.items()),
        }
        by_screening = f", {len(screened)} by the hidden-reference post-screening"
    counts = (
        f"{counted(len(rows), 'participant')} joined: {len(left_out)} left out by exclusions"
        f"{by_screening} and {counted(pilots, 'pilot')} (never analysed)."
    )
    return render_template(
        "experimenter/report_no_votes.html",
        study=study,
        answer="rating" if study.design in RATING_DESIGNS else "vote",
        counts=counts,
        left_out=left_out,
        screening=screening,
        date=dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
    )


def report_head(study: Study, results: dict[str, Any], *, exclude: str | None) -> dict[str, Any]:
    """What the report says of the study itself (the study head of
    ``app.analysis.report.document``)."""

    from app.analysis.report.blocks import counted

    left_out = results["input"]["left_out"]
    design = (
        f"Design: {study.design}"
        + (f" against {study.reference}" if study.reference else "")
        + f"; conditions {', '.join(c.name for c in study.conditions)}; clips "
        f"{', '.join(c.name for c in study.clips)}; question: {study.question!r}; "
        + ("undecided answers allowed" if study.allow_undecided else "no undecided answer")
        + f"; {counted(study.catch_trials, 'catch trial')} per participant; replay "
        f"{study.replay}; target {counted(study.target_participants, 'participant')}."
    )
    included = results["input"]["participants"]
    who = (
        f"{counted(included, 'participant')} included, {len(left_out)} left out"
        + (
            " (" + "; ".join(f"{p}: {why}" for p, why in sorted(left_out.items())) + ")"
            if left_out
            else ""
        )
        + "."
    )
    command = [
        "facepair",
        "analyze",
        "votes.csv",
        "--report",
        "report.html",
        "--pdf",
        "report.pdf",
        "--conditions",
        ",".join(c.name for c in study.conditions),
    ]
    if exclude:
        command += ["--exclude", exclude]

    kept = {str(p) for p in results["participants"]}
    return {
        "title": study.title,
        "design": design,
        "participants": who,
        "questionnaire": answers_summary(study, included=kept),
        "date": dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "command": shlex.join(command),
        "votes_file": "votes.csv",
    }
