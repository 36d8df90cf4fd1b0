"""A study's mesh files in its media folder, and back on the machine that runs a job.

A mesh condition's vertex file comes with the files it is read with (docs/reference/meshes.md):
its template beside it under its name (``face.npy`` and ``face.obj``), perhaps a head pose
(``face.pose.npy``), and the study's ``[meshes]`` (or the condition's ``mesh``) files: a
template, a region file or CodeTalker's region folder, the user's own FLAME model. Creating the
study copies them into its folder (:func:`copy_mesh_files`, :func:`copy_siblings`), storing the
options with the copies' names; a job puts them back on its machine (:func:`fetch_mesh_options`,
:func:`fetch_siblings`) so every worker, local or elsewhere, reads the same files.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from app.stimuli.meshes.meshfile import MESH_SUFFIXES
from app.stimuli.meshes.source import is_mesh_path
from app.web.infra import media
from app.web.models import Study

#: Files beside a vertex file that go with it: its template, its head pose.
SIBLING_SUFFIXES: tuple[str, ...] = (*MESH_SUFFIXES, ".pose.npy")
#: The options that name files.
FILE_OPTIONS: tuple[str, ...] = ("template", "regions", "flame_model")
#: CodeTalker's region files, copied from a region folder.
REGION_FILES: tuple[str, ...] = ("lve.txt", "fdd.txt")

Copy = Callable[[Study, Path, str], str]


def _sibling(path: Path, suffix: str) -> Path:
    return path.with_name(path.stem + suffix)


def copy_siblings(study: Study, source: Path, stored: str, copy: Copy) -> list[str]:
    """Copy the template and head pose beside a mesh file ``source`` next to its stored copy
    ``stored``, under the stored copy's name (a ground truth is stored as ``ground_truth``);
    returns the copies' names (the study records them: :func:`fetch_siblings`)."""
    if not is_mesh_path(source):
        return []
    copied = []
    for suffix in SIBLING_SUFFIXES:
        for candidate in (_sibling(source, suffix), _sibling(source, suffix.upper())):
            if candidate.is_file():
                rel = str(Path(stored).with_name(Path(stored).stem + suffix))
                copied.append(copy(study, candidate, rel))
                break
    return copied


def copy_mesh_files(
    study: Study, options: Mapping[str, Any], folder: str, copy: Copy
) -> dict[str, Any]:
    """``options`` with each named file (or region folder) copied under ``folder`` and named
    by its stored path."""
    out = dict(options)
    for key in FILE_OPTIONS:
        value = options.get(key)
        if not value:
            continue
        path = Path(str(value))
        if path.is_dir():
            for name in REGION_FILES:
                if (path / name).is_file():
                    copy(study, path / name, f"{folder}/{key}/{name}")
            out[key] = f"{folder}/{key}/"
        else:
            out[key] = copy(study, path, f"{folder}/{key}{path.suffix.lower()}")
    return out


def fetch_siblings(study: Study, rel: str) -> None:
    """Bring the files stored beside a mesh file ``rel`` (those the study recorded in its
    ``mesh_files`` setting) to this machine."""
    if not is_mesh_path(rel):
        return
    siblings = {str(Path(rel).with_name(Path(rel).stem + s)) for s in SIBLING_SUFFIXES}
    for stored in study.settings.get("mesh_files") or ():
        if stored in siblings:
            media.fetch(study, stored)


def fetch_mesh_options(study: Study, options: Mapping[str, Any] | None) -> dict[str, Any]:
    """Stored ``options`` with their files on this machine, named by their local paths."""
    out = dict(options or {})
    for key in FILE_OPTIONS:
        rel = out.get(key)
        if not rel:
            continue
        if str(rel).endswith("/"):
            local: Path | None = None
            for name in REGION_FILES:
                if media.stored(study, f"{rel}{name}"):
                    local = media.fetch(study, f"{rel}{name}").parent
            out[key] = str(local) if local is not None else str(rel)
        else:
            out[key] = str(media.fetch(study, str(rel)))
    return out


def fetch_bundle(study: Study, track_rel: str) -> None:
    """Bring a generated mesh condition's bundle (``<name>.mesh.npz`` beside its ``.fap``, which
    names it) to this machine."""
    from app.stimuli.io import MESH_COMMENT

    track = media.fetch(study, track_rel)
    with open(track, encoding="utf-8", errors="replace") as fh:
        head = [fh.readline() for _ in range(3)]
    if any(line.startswith(MESH_COMMENT) for line in head):
        media.fetch(study, str(Path(track_rel).with_suffix(".mesh.npz")))


def publish_bundle(study: Study, track_rel: str, root: Path) -> None:
    """Publish the bundle ``save_track`` wrote beside the track ``track_rel``, if it did."""
    bundle = str(Path(track_rel).with_suffix(".mesh.npz"))
    if (root / bundle).is_file():
        media.publish(study, bundle)
