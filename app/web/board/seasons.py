"""Seasons: creating one from its file, reading it back, and checking its pins.

:func:`create_season` copies the segments (speech, ground truth) and the avatar into the
season's folder, writes the manifest (every file and setting by SHA-256,
:func:`app.leaderboard.manifest.build_manifest`), adds the season's fixed anchors as systems and
makes the anchors' single-face study, whose clips the board links as their renders. Nothing is
committed: the caller commits, then starts the returned jobs (:func:`start_jobs`).
"""

from __future__ import annotations

import hashlib
import secrets
import tomllib
from collections.abc import Iterable
from typing import Any

import sqlalchemy as sa
from flask import Flask

from app import __version__
from app.errors import InputError
from app.leaderboard.manifest import build_manifest, file_sha256, manifest_sha256
from app.leaderboard.season import SeasonSpec, parse_season
from app.stimuli.speechaudio import read_speech_audio
from app.trials.studyfile import parse_study
from app.web.board.models import BoardSystem, Season
from app.web.board.store import forget, keep, season_dir
from app.web.extensions import db
from app.web.models import Job, Study, User
from app.web.study.studies import create_study

#: How the board names the stimulus models that serve as anchors.
ANCHOR_NAMES = {
    "ground_truth": "Ground truth (captured motion)",
    "none": "No prosody (still head and brows)",
    "random": "Random motion",
    "speech_driven": "Speech-driven head (ARX)",
    "live_gmm": "Live head-and-eye model",
}


def season_by_name(name: str) -> Season | None:
    return db.session.scalar(sa.select(Season).where(Season.name == name))


def season_spec(season: Season) -> SeasonSpec:
    """The season as its file says, its paths naming the copies in the season's folder."""
    return parse_season(
        season.settings,
        source=f"{season.name}.toml",
        base_dir=season_dir(season),
        check_files=False,
    )


def draw_commitment(draw_seed: int) -> str:
    """The SHA-256 the manifest publishes of the secret draw seed."""
    return hashlib.sha256(f"facepair-draw-seed:{draw_seed}".encode()).hexdigest()


def create_season(
    spec: SeasonSpec, source_text: str, *, software: dict[str, str | None] | None = None
) -> tuple[Season, list[int]]:
    """Rows and files of a new season from its validated file; returns the season and the jobs
    to start after the commit (the anchors' renders)."""
    organiser = db.session.scalar(sa.select(User).where(User.email == spec.organiser))
    if organiser is None:
        raise InputError(
            f"no experimenter {spec.organiser!r} (add one with 'facepair experimenter add')",
            field="organiser",
        )
    if season_by_name(spec.name) is not None:
        raise InputError(f"a season named {spec.name!r} exists already", field="name")
    durations = {s.name: read_speech_audio(s.audio).duration for s in spec.segments}
    draw_seed = secrets.randbits(63)
    manifest = build_manifest(
        spec,
        season_file=source_text,
        durations=durations,
        draw_commitment=draw_commitment(draw_seed),
        software={"facepair": __version__, **(software or {})},
    )
    season = Season(
        name=spec.name,
        title=spec.title,
        organiser_id=organiser.id,
        source_toml=source_text,
        settings={},
        manifest=manifest,
        manifest_sha256=manifest_sha256(manifest),
        draw_seed=draw_seed,
    )
    db.session.add(season)
    db.session.flush()
    try:
        season.settings = _kept_settings(season, spec, source_text)
        stored = season_spec(season)
        for model in stored.rounds.anchors:
            db.session.add(
                BoardSystem(
                    season_id=season.id,
                    code=model,
                    name=ANCHOR_NAMES.get(model, model),
                    kind="anchor",
                    model=model,
                    status="queued",
                )
            )
        study = single_face_study(
            season,
            stored,
            title=f"{spec.title}: anchors",
            conditions=[{"name": a, "model": a} for a in stored.rounds.anchors],
        )
        season.anchors_study_id = study.id
        job = Job(study_id=study.id, kind="prepare")
        db.session.add(job)
        db.session.flush()
    except BaseException:
        forget(season)
        raise
    return season, [job.id]


def _kept_settings(season: Season, spec: SeasonSpec, source_text: str) -> dict[str, Any]:
    """The season file as a mapping whose paths name copies kept in the season's folder."""
    data = tomllib.loads(source_text)
    for item, segment in zip(data["segments"], spec.segments, strict=True):
        item["audio"] = keep(
            season, segment.audio, f"segments/{segment.name}/audio{segment.audio.suffix.lower()}"
        )
        item["ground_truth"] = keep(
            season,
            segment.ground_truth,
            f"segments/{segment.name}/ground_truth{segment.ground_truth.suffix.lower()}",
        )
    face = spec.face()
    if face is not None:
        data["render"]["face"] = keep(season, face, f"render/{face.name}")
        sidecar = face.with_name(face.stem + ".avatar.json")
        if sidecar.is_file():
            keep(season, sidecar, f"render/{sidecar.name}")
    return data


def single_face_study(
    season: Season, spec: SeasonSpec, *, title: str, conditions: list[dict[str, Any]]
) -> Study:
    """A draft single-face study of ``conditions`` on every segment with the season's render
    and stimulus settings (a system's preview, the anchors' renders); never opened."""
    mapping = spec.preview_mapping(
        title=title,
        seed=spec.seed,
        conditions=conditions,
        clips=segment_clips(spec, [s.name for s in spec.segments]),
    )
    study_spec = parse_study(mapping, source=f"{season.name}.toml", base_dir=season_dir(season))
    return create_study(season.organiser, study_spec, source_toml="")


def segment_clips(spec: SeasonSpec, names: Iterable[str]) -> list[dict[str, Any]]:
    """Study-file clips of the named segments (their kept files, absolute)."""
    by_name = {s.name: s for s in spec.segments}
    return [
        {
            "name": n,
            "audio": str(by_name[n].audio),
            "ground_truth": str(by_name[n].ground_truth),
        }
        for n in names
    ]


def verify_pins(season: Season) -> None:
    """Refuse (one line) when a kept segment file or the avatar no longer has the SHA-256 its
    manifest pinned: the season's frozen state has changed under it."""
    spec = season_spec(season)
    pinned = {s["name"]: s for s in season.manifest["segments"]}
    for segment in spec.segments:
        for key, path in (("audio", segment.audio), ("ground_truth", segment.ground_truth)):
            if not path.is_file() or file_sha256(path) != pinned[segment.name][f"{key}_sha256"]:
                raise InputError(
                    f"segment {segment.name}: its {key.replace('_', ' ')} is not the file the "
                    "manifest pinned (changed or missing); the season's state is no longer frozen",
                    field=season.name,
                )
    face = season.manifest["render"].get("face")
    avatar = spec.face()
    if face is not None and (avatar is None or file_sha256(avatar) != face["sha256"]):
        raise InputError(
            "the avatar is not the file the manifest pinned", field=f"{season.name}.render.face"
        )


def start_jobs(app: Flask, job_ids: Iterable[int]) -> None:
    """Hand committed job rows to their runner (``app.web.jobs.enqueue``)."""
    from app.web.jobs import enqueue

    for job_id in job_ids:
        enqueue(app, job_id)
