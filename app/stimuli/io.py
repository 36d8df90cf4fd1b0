"""Load and save motion tracks by file extension (.fap or .csv; a mesh or FLAME sequence)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from app.errors import InputError
from app.stimuli.fapfile import read_fap, write_fap
from app.stimuli.track import MotionTrack
from app.stimuli.trackcsv import read_track_csv, write_track_csv

#: Frame rate a tracker's file is resampled to when no rate is asked for.
IMPORT_FPS = 30.0


def load_track(
    path: str | Path, fps: float | None = None, *, mesh: Mapping[str, Any] | None = None
) -> MotionTrack:
    """Read a ``.fap`` or ``.csv`` motion track (``fps`` for a CSV without a ``# fps=`` line).

    A ``.csv`` written by a tracker or a tool (OpenFace 2.0, Live Link Face, Audio2Face-3D;
    :mod:`app.stimuli.capture`) is recognised by its header, a ``.json`` (Audio2Face,
    OpenFaceFX) by its keys and a ``.bvh`` by its skeleton, and imported at ``fps`` (default 30).
    A ``.npy``, ``.npz`` or ``.pkl`` is a mesh or FLAME sequence, read with the options
    ``mesh`` (:class:`app.stimuli.meshes.source.MeshOptions`: template, fps, units, regions,
    pose, flame_model) into a track of its head's turn at ``fps`` that carries the mesh
    (:func:`app.stimuli.meshes.source.mesh_track`). A ``.fap`` facepair wrote for a mesh
    condition carries its mesh bundle beside it (:func:`save_track`).
    """
    suffix = Path(path).suffix.lower()
    if suffix in (".npy", ".npz", ".pkl"):
        from app.stimuli.meshes.source import MeshOptions, mesh_track

        options = mesh if isinstance(mesh, MeshOptions) else MeshOptions.from_mapping(mesh)
        return mesh_track(path, options, fps or IMPORT_FPS)
    if suffix == ".fap":
        track = read_fap(path)
        bundle = _bundle_named(path)
        if bundle is not None:
            spec = {"bundle": str(bundle.resolve()), "label": bundle.name}
            track = track.replace(metadata={**track.metadata, "mesh": spec})
        return track
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


#: The comment line naming a mesh condition's bundle in its ``.fap``.
MESH_COMMENT = "# mesh: "


def _bundle_named(path: str | Path) -> Path | None:
    """The mesh bundle a ``.fap``'s header names (``# mesh: <name>.mesh.npz``), if any."""
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            for _, line in zip(range(12), fh, strict=False):
                if line.startswith(MESH_COMMENT):
                    return Path(path).with_name(Path(line[len(MESH_COMMENT) :].strip()).name)
    except OSError:
        return None
    return None


def save_track(track: MotionTrack, path: str | Path, *, greta: bool = False) -> None:
    """Write a motion track as ``.fap`` or ``.csv`` by the path's extension.

    ``greta``: a ``.fap`` in Greta's dialect instead of Xface's (:func:`write_fap`). A mesh
    condition's ``.fap`` holds its head's turn and the shared channels; its vertices go beside
    it as ``<name>.mesh.npz`` on the track's timeline
    (:func:`app.stimuli.meshes.source.save_bundle_beside`), named in a comment line.
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".fap":
        write_fap(track, path, greta=greta)
        from app.stimuli.meshes.source import save_bundle_beside

        bundle = save_bundle_beside(track, path)
        if bundle is not None:
            text = Path(path).read_text(encoding="utf-8")
            first, _, rest = text.partition("\n")
            Path(path).write_text(f"{first}\n{MESH_COMMENT}{bundle.name}\n{rest}", "utf-8")
    elif greta:
        raise InputError(
            f"Greta's dialect is a .fap format, not {suffix or 'no extension'}", path=path
        )
    elif suffix == ".csv":
        write_track_csv(track, path)
    else:
        raise InputError(f"unknown motion track type {suffix!r}: expected .fap or .csv", path=path)
