"""Submissions: a team's system checked at upload, kept, rendered for its private preview, queued.

One path for the web form, the JSON endpoint and ``facepair leaderboard submit``:
:func:`submit` checks the description (one line per field) and every file
(:func:`app.leaderboard.checks.check_submission`, one line per problem, naming the file), and
only a submission that passes becomes rows: the submitter (new, with a key shown once, or
proved by that key), the system with its drawn samples, and its preview study (the system and
the no-prosody face, one clip per segment, rendered exactly as a round will). Nothing is public
until a round that compared it is published; the submitter sees the preview at its private link
and queues it for the next round (:func:`queue_system`).
"""

from __future__ import annotations

import datetime as dt
import hashlib
import re
import secrets
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import sqlalchemy as sa

from app.errors import InputError
from app.leaderboard.checks import SegmentTarget, check_submission
from app.trials.fields import NAME_PATTERN
from app.web.board.models import BoardSystem, Season, Submitter
from app.web.board.seasons import season_spec, single_face_study
from app.web.board.store import keep, season_file
from app.web.extensions import db
from app.web.infra.accounts import normalise_email
from app.web.infra.limits import check
from app.web.models import Job, utcnow

#: The preview's comparison face: the still head every season can make.
PREVIEW_BASELINE = "none"
_URL = re.compile(r"https?://[^\s/]+[^\s]*")


class SubmissionRefused(InputError):
    """The submission does not pass: every problem, one line each (the first is the message)."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = list(problems)
        super().__init__(self.problems[0] if self.problems else "refused")


@dataclass(frozen=True)
class Description:
    """What a submitter says of a system (the form's fields)."""

    system: str
    team: str = ""
    contact: str = ""
    paper: str = ""
    training_data: str = ""
    licence: bool = False
    anonymous_name: str = ""
    anonymous_until: str = ""
    key: str = ""

    @classmethod
    def from_mapping(cls, form: Mapping[str, Any]) -> Description:
        """From a form or JSON object: strings only (anything else is refused, named)."""
        values: dict[str, Any] = {}
        for name in cls.__dataclass_fields__:
            value = form.get(name, "" if name != "licence" else False)
            if name == "licence":
                values[name] = value is True or str(value).lower() in ("1", "true", "yes", "on")
            elif not isinstance(value, str):
                raise InputError("expected text", field=name)
            else:
                values[name] = value.strip()
        return cls(**values)


def key_hash(key: str) -> str:
    return hashlib.sha256(key.encode("utf-8", "replace")).hexdigest()


def _describe(season: Season, form: Description) -> tuple[list[str], dt.date | None]:
    """The description's problems, one line per field, and the anonymity date."""
    problems: list[str] = []
    if not form.system:
        problems.append("system: missing (the system's name, as a paper would call it)")
    elif len(form.system) > 80 or any(not c.isprintable() for c in form.system):
        problems.append("system: at most 80 printable characters")
    if not form.key:
        if not form.team:
            problems.append("team: missing (or give your submitter key)")
        try:
            normalise_email(form.contact)
        except InputError as exc:
            problems.append(f"contact: {exc.message}")
    if form.paper and not _URL.fullmatch(form.paper):
        problems.append(f"paper: expected an http:// or https:// link, got {form.paper!r}")
    if not form.training_data:
        problems.append("training_data: missing (the data the system was trained on)")
    if not form.licence:
        licence = season.manifest.get("licence", "")
        problems.append(
            f"licence: the tracks, their renders and the votes on them are published under "
            f"{licence}; grant it to submit"
        )
    until = None
    if form.anonymous_until:
        try:
            until = dt.date.fromisoformat(form.anonymous_until)
        except ValueError:
            problems.append(
                f"anonymous_until: expected a date YYYY-MM-DD, got {form.anonymous_until!r}"
            )
        else:
            if until <= dt.date.today():
                problems.append("anonymous_until: a date after today")
            if not form.anonymous_name:
                problems.append("anonymous_name: missing (the name shown until that date)")
    if form.anonymous_name and not NAME_PATTERN.match(form.anonymous_name.replace(" ", "_")):
        problems.append("anonymous_name: letters, digits, spaces, _ . - (at most 64)")
    taken = db.session.scalar(
        sa.select(BoardSystem.id).where(
            BoardSystem.season_id == season.id,
            sa.func.lower(BoardSystem.name).in_(
                [form.system.lower(), form.anonymous_name.lower() or form.system.lower()]
            ),
        )
    )
    if form.system and taken is not None:
        problems.append(f"system: a system named {form.system!r} is in this season already")
    return problems, until


def _submitter(season: Season, form: Description) -> tuple[Submitter, str | None]:
    """The submitter the key proves, or a new one with its key (returned once)."""
    if form.key:
        found = db.session.scalar(
            sa.select(Submitter).where(
                Submitter.key_hash == key_hash(form.key), Submitter.season_id == season.id
            )
        )
        if found is None:
            raise SubmissionRefused(["key: no submitter of this season has this key"])
        return found, None
    key = secrets.token_urlsafe(24)
    submitter = Submitter(
        season_id=season.id,
        team=check(Submitter.team, form.team, "team"),
        contact=normalise_email(form.contact),
        key_hash=key_hash(key),
    )
    db.session.add(submitter)
    return submitter, key


def submit(
    season: Season, form: Description, files: Mapping[str, Path]
) -> tuple[BoardSystem, str | None, list[int]]:
    """Check and keep a submission. Returns the system, the new submitter key (None when a
    key was given) and the jobs to start after the commit (its preview's renders). Raises
    :class:`SubmissionRefused` with every problem; nothing is written then."""
    if season.status != "open":
        raise SubmissionRefused([f"season {season.name}: closed; it takes no submissions"])
    problems, until = _describe(season, form)
    spec = season_spec(season)
    code = f"sys-{secrets.token_hex(3)}"
    targets = [
        SegmentTarget(s["name"], float(s["duration_s"])) for s in season.manifest["segments"]
    ]
    result = check_submission(
        files, targets, spec.submissions, system=code, draw_seed=season.draw_seed
    )
    problems += list(result.problems)
    if problems:
        raise SubmissionRefused(problems)
    submitter, key = _submitter(season, form)
    db.session.flush()
    kept: dict[str, dict[str, Any]] = {}
    for report in result.files:
        rel = keep(season, files[report.file], f"systems/{code}/{report.file}")
        entry = kept.setdefault(report.segment, {"samples": []})
        entry["samples"].append(rel)
        if result.drawn[report.segment] == report.file:
            entry["drawn"] = rel
    system = BoardSystem(
        season_id=season.id,
        code=code,
        name=form.system,
        kind="submitted",
        status="previewing",
        submitter_id=submitter.id,
        paper=form.paper,
        training_data=form.training_data,
        licence=str(season.manifest.get("licence", "")),
        licence_granted_at=utcnow(),
        anonymous_name=form.anonymous_name or None,
        anonymous_until=until,
        check=result.as_dict(),
        files=kept,
    )
    db.session.add(system)
    db.session.flush()
    study = single_face_study(
        season,
        spec,
        title=f"{season.title}: preview of {code}",
        conditions=[
            {
                "name": code,
                "tracks": {seg: str(season_file(season, f["drawn"])) for seg, f in kept.items()},
            },
            {"name": PREVIEW_BASELINE, "model": PREVIEW_BASELINE},
        ],
    )
    system.preview_study_id = study.id
    job = Job(study_id=study.id, kind="prepare")
    db.session.add(job)
    db.session.flush()
    return system, key, [job.id]


def refresh(system: BoardSystem) -> BoardSystem:
    """A previewing system whose preview study is rendered is ``preview``."""
    if system.status == "previewing" and system.preview_study is not None:
        if system.preview_study.status == "ready":
            system.status = "preview"
    return system


def preview_job(system: BoardSystem) -> Job | None:
    """The latest job of the system's preview study."""
    if system.preview_study_id is None:
        return None
    return db.session.scalar(
        sa.select(Job).where(Job.study_id == system.preview_study_id).order_by(Job.id.desc())
    )


def queue_system(system: BoardSystem) -> None:
    """Queue a previewed system for the next round (its submitter saw its renders)."""
    refresh(system)
    if system.status == "queued":
        return
    if system.status != "preview":
        raise InputError(
            f"the system is {system.status}; only a rendered preview can be queued",
            field="status",
        )
    system.status = "queued"
    system.queued_at = utcnow()


def by_preview_token(season: Season, token: str) -> BoardSystem | None:
    return db.session.scalar(
        sa.select(BoardSystem).where(
            BoardSystem.season_id == season.id,
            BoardSystem.preview_token == token,
            BoardSystem.kind == "submitted",
        )
    )


def public_name(system: BoardSystem, today: dt.date | None = None) -> str:
    """The name the board shows: the anonymous name until its date, else the system's."""
    today = today or dt.date.today()
    if system.anonymous_name and system.anonymous_until and today < system.anonymous_until:
        return system.anonymous_name
    return system.name


def is_anonymous(system: BoardSystem, today: dt.date | None = None) -> bool:
    return public_name(system, today) != system.name
