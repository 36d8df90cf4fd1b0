"""The options of a track or condition that is a mesh or FLAME sequence, shared by
``facepair render`` and ``facepair stimuli generate`` (docs/reference/meshes.md)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click


def mesh_options(fn: Callable) -> Callable:
    """Options of a track that is a mesh or FLAME sequence (docs/reference/meshes.md)."""
    fn = click.option(
        "--mesh-eyes",
        type=click.Choice(["match", "own"]),
        default="match",
        show_default=True,
        help="Beside a mesh, which cannot blink: match (no face blinks; no gaze unless every "
        "mesh has eyeballs) or own (each face as it comes).",
    )(fn)
    fn = click.option(
        "--flame-model",
        type=click.Path(dir_okay=False),
        default=None,
        help="Your own FLAME model file for a FLAME parameter track (default: "
        "$FACEPAIR_FLAME_MODEL); facepair never ships or downloads FLAME.",
    )(fn)
    fn = click.option(
        "--regions",
        type=click.Path(),
        default=None,
        help="Lip (and upper-face) vertices of the mesh: a region file or CodeTalker's "
        "regions/ folder (default: found from the motion).",
    )(fn)
    fn = click.option(
        "--units",
        type=click.Choice(["auto", "m", "cm", "mm", "biwi"]),
        default="auto",
        show_default=True,
        help="Units of a vertex track (biwi: BIWI as FaceFormer stores it, 0.2 m a unit).",
    )(fn)
    fn = click.option(
        "--mesh-fps",
        type=float,
        default=None,
        help="Frame rate of a vertex or FLAME track (.npy/.npz/.pkl): the files do not say it.",
    )(fn)
    fn = click.option(
        "--template",
        type=click.Path(dir_okay=False),
        default=None,
        help="Template mesh (.obj/.ply) of a vertex track (default: the one beside it under "
        "its name, face.npy -> face.obj).",
    )(fn)
    return fn


def mesh_settings(
    template: str | None,
    mesh_fps: float | None,
    units: str,
    regions: str | None,
    flame_model: str | None,
) -> dict[str, Any]:
    """The options as the mapping :class:`app.stimuli.meshes.source.MeshOptions` reads."""
    return {
        "template": template,
        "fps": mesh_fps,
        "units": units,
        "regions": regions,
        "flame_model": flame_model,
    }
