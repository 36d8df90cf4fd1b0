"""A study's package (``app.analysis.package`` reads it back): one zip with the study file,
the votes the report analysed, the participants and answers exports, the report and its
numbers, and a manifest with the SHA-256 of every file and of every clip, track and video, the
seeds, the software versions and the command that reproduces the analysis.
"""

from __future__ import annotations

import datetime as dt
import io
import json
import platform
import tomllib
import zipfile
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Any

import sqlalchemy as sa
from werkzeug.utils import secure_filename

from app import __version__
from app.analysis.package import (
    MANIFEST,
    PACKAGE_FORMAT,
    RATINGS,
    RESULTS,
    VOTES,
    analysis_command,
    sha256_bytes,
    sha256_file,
)
from app.errors import InputError
from app.trials.design import RATING_DESIGNS
from app.trials.fields import upload_name
from app.trials.studyfile import loads_study
from app.web.extensions import db
from app.web.infra import media
from app.web.infra.storage import report_path
from app.web.models import Condition, Participant, Stimulus, Study, Track
from app.web.study.labels import participant_label
from app.web.study.privacy import participants_csv
from app.web.study.questionnaires import answers_csv

#: The libraries whose versions decide the numbers (with Python's and facepair's).
LIBRARIES = ("numpy", "scipy", "pandas", "statsmodels", "matplotlib")
#: The report's files copied into the package when present, in the zip's order (the table
#: analysed first: ratings.csv in place of votes.csv for the rating designs).
REPORT_FILES = ("report.html", "report.pdf", RESULTS)


def package_name(study: Study) -> str:
    """The package's file name: the study's title made safe, then ``-package.zip``."""
    return (secure_filename(study.title) or f"study-{study.id}") + "-package.zip"


def _library_version(name: str) -> str | None:
    try:
        return version(name)
    except PackageNotFoundError:
        return None


def media_manifest(study: Study) -> list[dict[str, Any]]:
    """Every clip (speech and ground truth), track, avatar and rendered video of ``study`` with its
    path in the study's media folder and SHA-256 (None where the file is missing)."""
    entries: list[tuple[str, str, str]] = []
    for clip in study.clips:
        entries.append(("clip", clip.name, clip.audio_path))
        if clip.ground_truth_path:
            entries.append(("ground truth", clip.name, clip.ground_truth_path))
    tracks = db.session.scalars(
        sa.select(Track)
        .join(Condition, Track.condition_id == Condition.id)
        .where(Condition.study_id == study.id)
        .order_by(Condition.position, Track.clip_id)
    )
    entries += [("track", f"{t.condition.name} / {t.clip.name}", t.path) for t in tracks]
    face = (study.settings.get("render") or {}).get("face")
    if face:  # the avatar every clip was rendered with
        entries.append(("avatar", Path(str(face)).name, str(face)))
    videos = db.session.scalars(
        sa.select(Stimulus)
        .where(Stimulus.study_id == study.id, Stimulus.video_path.is_not(None))
        .order_by(Stimulus.id)
    )
    for s in videos:
        shown = f"{s.clip.name}: {s.left.name} | {s.right.name}"
        if s.instruction:
            shown += f" (check: {s.instruction})"
        if s.foreign_side:
            shown += f" (mismatched {s.foreign_side})"
        entries.append(("video", shown, s.video_path or ""))
        if s.webm_path:  # the same clip for browsers without H.264: some saw this file
            entries.append(("video (WebM)", shown, s.webm_path))
    out = []
    for kind, name, rel in entries:
        path = media.fetch(study, rel)
        out.append(
            {
                "kind": kind,
                "name": name,
                "path": rel,
                "sha256": sha256_file(path) if path.is_file() else None,
            }
        )
    return out


def _absolute(path: str) -> bool:
    return PurePosixPath(path).is_absolute() or PureWindowsPath(path).is_absolute()


def packaged_study_file(text: str) -> str:
    """The study file as the package holds it: as it was written, but every file it names by
    an absolute path (a study file read on the server, ``facepair study create``) named by its
    file name, as the web form's study file names them: a package never names a server path.

    >>> print(packaged_study_file('[[clips]]\\nname = "s1"\\naudio = "/srv/lab/s1.wav"\\n'), end="")
    [[clips]]
    name = "s1"
    audio = "s1.wav"
    """
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return text
    named: list[Any] = [document.get("render", {}).get("face")]
    for clip in document.get("clips", []):
        named += [clip.get("audio"), clip.get("ground_truth")]
    for condition in document.get("conditions", []):
        named += list(condition.get("tracks", {}).values())
    for path in {p for p in named if isinstance(p, str) and _absolute(p)}:
        for literal in (json.dumps(path, ensure_ascii=False), f"'{path}'"):
            text = text.replace(literal, json.dumps(upload_name(path), ensure_ascii=False))
    if any(isinstance(p, str) and _absolute(p) and p in text for p in named):
        # written with escapes the plain forms above miss: the study as the file it amounts to
        try:
            return loads_study(text, check_files=False).to_portable_toml()
        except InputError:  # a file of an older schema: as written
            return text
    return text


def build_package(study: Study) -> bytes:
    """The study's package as zip bytes. Needs a written report (the package holds the votes
    it analysed, so its numbers are the report's); raises InputError naming what is missing."""
    table = RATINGS if study.design in RATING_DESIGNS else VOTES
    folder = report_path(study).parent.name
    report: dict[str, bytes] = {}
    for name in (table, *REPORT_FILES):
        path = media.fetch(study, f"{folder}/{name}")
        if path.is_file():
            report[name] = path.read_bytes()
    if "report.html" not in report or table not in report:
        raise InputError(
            "no report yet: close the study (or press Write report) first", field="package"
        )
    results = json.loads(report[RESULTS]) if RESULTS in report else None
    if results is not None and results.get("input", {}).get("source") not in (None, table):
        # a report written before reports named their table by its place: the server's path
        results["input"]["source"] = table
        report[RESULTS] = (json.dumps(results, indent=1, allow_nan=False) + "\n").encode()
    members: dict[str, bytes] = {
        "study.toml": packaged_study_file(study.source_toml).encode("utf-8"),
        **report,
        "participants.csv": participants_csv(study).encode("utf-8"),
        "answers.csv": answers_csv(study).encode("utf-8"),
    }
    people = db.session.execute(
        sa.select(Participant.number, Participant.seed)
        .where(Participant.study_id == study.id)
        .order_by(Participant.number)
    ).all()
    name = package_name(study)
    options = (results or {}).get("options", {})
    manifest = {
        "format": PACKAGE_FORMAT,
        "study": {
            "title": study.title,
            "status": study.status,
            "design": study.design,
            "conditions": [c.name for c in study.conditions],
            "clips": [c.name for c in study.clips],
            "report_at": study.report_at.isoformat() if study.report_at else None,
        },
        "packaged_at": dt.datetime.now(dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "software": {
            "facepair": __version__,
            "python": platform.python_version(),
            **{lib: _library_version(lib) for lib in LIBRARIES},
        },
        "seeds": {
            "study": study.seed,
            "participants": {participant_label(n): seed for n, seed in people},
            "bootstrap": options.get("seed"),
        },
        "analysis": None
        if results is None
        else {
            "conditions": results["conditions"],
            "exclude": study.settings.get("exclude"),
            "undecided": options.get("undecided"),
            "bootstrap": options.get("bootstrap"),
            "command": analysis_command(name),
            "votes_command": results.get("study", {}).get("command"),
        },
        "files": {member: sha256_bytes(data) for member, data in members.items()},
        "media": media_manifest(study),
    }
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr(MANIFEST, json.dumps(manifest, indent=1) + "\n")
        for member, data in members.items():
            archive.writestr(member, data)
    return buffer.getvalue()
