"""Content-addressed clip cache: the same render is free the second time.

The key is a SHA-256 over everything that changes the output - the kind of clip, the motion
tracks (frame rate, channels, values), the audio file's bytes, the face (mesh, feature points,
FAPU, weights), the render settings and the renderer version - so a changed input never serves
a stale clip. Entries are written to a temporary name and renamed into place.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from typing import Any

from app.stimuli.track import MotionTrack


def track_digest(track: MotionTrack) -> str:
    """SHA-256 of a track's frame rate, channels and values (not its name or metadata)."""
    h = hashlib.sha256()
    h.update(f"{track.fps!r}|{track.channels}|{track.values.shape}".encode())
    h.update(track.values.astype("<f8").tobytes())
    return h.hexdigest()


def file_digest(path: str | Path | None) -> str:
    """SHA-256 of a file's bytes ('' for no file)."""
    if path is None:
        return ""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def cache_key(
    kind: str,
    tracks: list[MotionTrack],
    audio_path: str | Path | None,
    face_hash: str,
    settings: Any,
    version: str,
) -> str:
    """The cache key of one clip (hex); ``settings`` gives the fields that change the output
    through ``output_fields()`` (see :class:`renderer.api.RenderSettings`)."""
    settings_dict = settings.output_fields()
    payload = {
        "kind": kind,
        "version": version,
        "tracks": [track_digest(t) for t in tracks],
        "audio": file_digest(audio_path),
        "face": face_hash,
        "settings": settings_dict,
    }
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()


def cached_path(cache_dir: str | Path, key: str, suffix: str) -> Path:
    return Path(cache_dir) / f"{key[:40]}{suffix}"


def deliver(source: Path, out_path: Path) -> Path:
    """Copy a cached clip to ``out_path`` (atomically) unless it is the same file."""
    out_path.parent.mkdir(parents=True, exist_ok=True)
    if source.resolve() != out_path.resolve():
        tmp = out_path.with_name(out_path.name + ".part")
        shutil.copyfile(source, tmp)
        tmp.replace(out_path)
    return out_path
