"""Rendering a study's clips: what every runner of a render shares, whether one job renders
them all in turn (:func:`app.web.jobs.bodies.render_clips`) or each clip is a job of its own on
the RQ workers (:mod:`app.web.jobs.clips`).

The renderer is imported inside :func:`render_stimulus`: the web process never loads its GL stack.
"""

from __future__ import annotations

import hashlib
import hmac
from collections.abc import Callable
from pathlib import Path
from typing import Any

import sqlalchemy as sa
from flask import current_app

from app.trials.design import RATING_DESIGNS
from app.web.extensions import db
from app.web.infra import media
from app.web.infra.storage import media_dir
from app.web.jobs.renditions import add_webm, has_webm, webm_file
from app.web.models import Clip, Stimulus, Study, Track


def render_inputs(study: Study) -> tuple[dict[tuple[int, int], str], list[Stimulus]]:
    """The study's track paths by (condition, clip) and its stimuli in order; raises when a
    stimulus has no track to show yet."""
    tracks = {
        (t.condition_id, t.clip_id): t.path
        for t in db.session.scalars(sa.select(Track).join(Clip).where(Clip.study_id == study.id))
    }
    stimuli = db.session.scalars(
        sa.select(Stimulus).where(Stimulus.study_id == study.id).order_by(Stimulus.id)
    ).all()
    if any(key not in tracks for s in stimuli for key in _track_keys(s)):
        raise ValueError("generate the tracks first: some conditions have no track yet")
    return tracks, list(stimuli)


def render_stimulus(
    study: Study,
    stim: Stimulus,
    tracks: dict[tuple[int, int], str],
    progress: Callable[[int, int], None],
) -> str:
    """Render one stimulus video (``renderer.render_pair``; ``renderer.render_single`` for
    the rating design's single faces) with its WebM rendition from the same frames, record
    and publish both; returns the MP4's path in the study's folder. A stimulus whose MP4 is
    in place already (rendered before renditions, or by a job stopped before its WebM) gets
    only the WebM, made from that MP4 (:mod:`app.web.jobs.renditions`). ``progress(frame,
    frames)`` is called every frame."""
    import renderer
    from app.stimuli.io import load_track

    if stim.video_path and media.stored(study, stim.video_path):
        add_webm(study, stim)
        db.session.commit()
        return stim.video_path
    root = media_dir(study)
    settings = renderer.RenderSettings(**render_settings(study))
    rel = clip_file(study, stim)
    (root / rel).parent.mkdir(parents=True, exist_ok=True)
    from app.web.study.meshmedia import fetch_bundle

    for key in _track_keys(stim):
        fetch_bundle(study, tracks[key])  # a mesh condition's vertices, beside its track
    left, right = (
        load_track(media.fetch(study, tracks[(condition, clip)]))
        for condition, clip in _track_keys(stim)
    )
    if stim.foreign_side:
        # The lent motion is time-aligned to this clip's speech and trimmed to its length.
        matched = right if stim.foreign_side == "left" else left
        lent = (
            (left if stim.foreign_side == "left" else right)
            .resample(matched.fps)
            .fit_length(matched.n_frames)
        )
        left, right = (lent, right) if stim.foreign_side == "left" else (left, lent)
    caption = {"caption": f"press {stim.instruction}"} if stim.instruction else {}
    audio = media.fetch(study, stim.clip.audio_path)
    webm = webm_file(rel)
    out = {
        "settings": settings,
        "cache_dir": root / "cache",
        "progress": progress,
        "webm_path": root / webm,
    }
    if study.design in RATING_DESIGNS:  # one face, rated on its own
        renderer.render_single(left, audio, root / rel, **out)
    else:
        renderer.render_pair(left, right, audio, root / rel, **out, **caption)
    media.publish(study, rel)
    stim.video_path = rel
    if (root / webm).is_file():
        media.publish(study, webm)
        stim.webm_path = webm
    else:  # a renderer that wrote the MP4 alone: the WebM from it
        add_webm(study, stim)
    db.session.commit()
    return rel


def render_settings(study: Study) -> dict[str, Any]:
    """The study's ``[render]`` settings, its avatar (and the avatar's sidecar) fetched to this
    machine and named by their local path."""
    settings = dict(study.settings.get("render") or {})
    if settings.get("face"):
        rel = str(settings["face"])
        sidecar = str(Path(rel).with_name(Path(rel).stem + ".avatar.json"))
        if media.stored(study, sidecar):
            media.fetch(study, sidecar)
        settings["face"] = str(media.fetch(study, rel))
    return settings


def rendered(study: Study, stim: Stimulus) -> bool:
    """Whether the stimulus's video and its WebM rendition are in place (a retried job keeps
    them; one with the MP4 alone gets the WebM)."""
    return bool(stim.video_path) and media.stored(study, stim.video_path) and has_webm(study, stim)


def rendering_finished(study: Study, total: int, kept: int, workers: int = 0) -> str:
    """Mark a draft study ready once every clip is rendered; the job's closing message."""
    if study.status == "draft":
        study.status = "ready"
    db.session.commit()
    by = f" by {workers} workers" if workers > 1 else ""
    return f"{total} clips rendered{by}" + (f" ({kept} kept from before)" if kept else "")


def _track_keys(stim: Stimulus) -> list[tuple[int, int]]:
    """(condition, clip) of the motion on each side: an appropriateness pair's foreign side
    shows the motion made for its ``foreign_clip``."""
    clips = [
        stim.foreign_clip_id if stim.foreign_side == side and stim.foreign_clip_id else stim.clip_id
        for side in ("left", "right")
    ]
    return [(stim.left_id, clips[0]), (stim.right_id, clips[1])]


def clip_file(study: Study, stim: Stimulus) -> str:
    """The stored name of a stimulus's clip: ``videos/<20 hex digits>.mp4``, an HMAC of the
    study and stimulus under the app's secret key. It names no condition, side, attention
    check or mismatched side, and cannot be guessed from the stimulus's number, so neither
    an object key, a redirect nor a proxy's path tells a participant what the clip shows
    (docs/reference/web.md, "Blinding"); the same stimulus keeps its name when a job is retried."""
    key = str(current_app.config["SECRET_KEY"]).encode()
    digest = hmac.new(key, f"clip/{study.id}/{stim.id}".encode(), hashlib.sha256).hexdigest()
    return f"videos/{digest[:20]}.mp4"
