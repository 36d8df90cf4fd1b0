"""Load and save motion tracks by file extension (.fap or .csv)."""

from __future__ import annotations

from pathlib import Path

from app.errors import InputError
from app.stimuli.fapfile import read_fap, write_fap
from app.stimuli.track import MotionTrack
from app.stimuli.trackcsv import read_track_csv, write_track_csv

#: Frame rate a tracker's file is resampled to when no rate is asked for.
IMPORT_FPS = 30.0


def load_track(path: str | Path, fps: float | None = None) -> MotionTrack:
    """Read a ``.fap`` or ``.csv`` motion track (``fps`` for a CSV without a ``# fps=`` line).

    A ``.csv`` written by a tracker or a tool (OpenFace 2.0, Live Link Face, Audio2Face-3D;
    :mod:`app.stimuli.capture`) is recognised by its header, a ``.json`` (Audio2Face,
    OpenFaceFX) by its keys and a ``.bvh`` by its skeleton, and imported at ``fps`` (default 30).
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".fap":
        return read_fap(path)
    if suffix == ".csv":
        from app.stimuli.capture import import_track, sniff_csv

        kind = sniff_csv(path)
        if kind is not None:
            return import_track(path, kind, fps or IMPORT_FPS)
        return read_track_csv(path, fps=fps)
    if suffix in (".json", ".bvh"):
        # A speech-driven tool's weights (Audio2Face, OpenFaceFX) or a BVH skeleton's head.
        from app.stimuli.capture import import_track

        return import_track(path, None, fps or IMPORT_FPS)
    raise InputError(
        f"unknown motion track type {suffix!r}: expected .fap, .csv, .json or .bvh", path=path
    )


def save_track(track: MotionTrack, path: str | Path, *, greta: bool = False) -> None:
    """Write a motion track as ``.fap`` or ``.csv`` by the path's extension.

    ``greta``: a ``.fap`` in Greta's dialect instead of Xface's (:func:`write_fap`).
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".fap":
        write_fap(track, path, greta=greta)
    elif greta:
        raise InputError(
            f"Greta's dialect is a .fap format, not {suffix or 'no extension'}", path=path
        )
    elif suffix == ".csv":
        write_track_csv(track, path)
    else:
        raise InputError(f"unknown motion track type {suffix!r}: expected .fap or .csv", path=path)
