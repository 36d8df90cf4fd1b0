"""``facepair render``: motion tracks + audio -> side-by-side clips, single-face clips, stills."""

from __future__ import annotations

import sys
from collections.abc import Callable
from contextlib import contextmanager
from typing import Any

import click

from app.commands.meshopts import mesh_options, mesh_settings

_track = click.Path(dir_okay=False)


def _settings(size: int, mosaic_block: int, face: str | None, **extra: Any):
    from renderer import RenderSettings

    return RenderSettings(size=size, mosaic_block=mosaic_block, face=face, **extra)


def _clip_settings(
    size: int,
    mosaic_block: int,
    face: str | None,
    antialias: str,
    samples: str,
    look: str,
    fps: float | None,
    workers: int,
):
    """The settings of a clip command (``render pair`` and ``render single``) from its options."""
    return _settings(
        size,
        mosaic_block,
        face,
        antialias=antialias,
        samples=int(samples),
        fps=fps,
        workers=workers,
        look=look,
    )


def _fitted_to_audio(tracks: dict[str, Any], audio: str, fps: float | None, pad: bool) -> None:
    """Refuse (or, with ``pad``, say in a line) a track longer or shorter than the audio
    beyond :data:`app.stimuli.lengths.LENGTH_TOLERANCE_S`: the clip takes the audio's
    words, and a face frozen for its last seconds must not pass unnoticed."""
    from pathlib import Path

    from app.errors import InputError
    from app.stimuli.audiofile import read_audio
    from app.stimuli.lengths import length_note
    from app.stimuli.speechaudio import MAX_DURATION_S

    if not Path(audio).is_file():
        raise InputError("audio file not found", path=audio)
    decoded = read_audio(audio, max_duration=MAX_DURATION_S)
    seconds = len(decoded.samples) / decoded.sample_rate
    for path, track in tracks.items():
        rate = fps or track.fps
        note = length_note(
            track, round(seconds * rate), rate, what="track", path=Path(path).name, pad=pad
        )
        if note:
            click.echo(f"note: {Path(path).name}: {note}", err=True)


def _load(path: str, mesh: dict[str, Any]) -> Any:
    """A track file, a mesh or FLAME sequence read with the ``mesh`` options."""
    from app.stimuli.io import load_track

    return load_track(path, mesh=mesh)


def _mesh_notes(tracks: dict[str, Any], mesh_eyes: str) -> list[Any]:
    """The tracks with the eyes ``mesh_eyes`` gives them beside a mesh, each mesh's notes (and
    the eyes') a line each."""
    from app.stimuli.meshes.fairness import match_mesh_eyes

    for track in tracks.values():
        for note in track.metadata.get("mesh_notes", ()):
            click.echo(f"note: {note}", err=True)
    out, note = match_mesh_eyes(tracks, mesh_eyes)
    if note:
        click.echo(f"note: {note}", err=True)
    return list(out.values())


def _face_notes(settings: Any) -> None:
    """What was inferred about an avatar (how its eyes were found, a shape standing in for
    another), a line each, before the render (which reads the avatar from the same cache)."""
    from renderer.api import load_face

    if settings.face is not None:
        for note in getattr(load_face(settings), "notes", ()):
            click.echo(f"note: {note}", err=True)


@contextmanager
def _progress_bar(label: str):
    from tqdm import tqdm

    bar = tqdm(total=0, desc=label, unit="frame", file=sys.stderr, dynamic_ncols=True, leave=True)

    def update(done: int, total: int) -> None:
        if bar.total != total:
            bar.total = total
        bar.update(done - bar.n)

    try:
        yield update
    finally:
        bar.close()


def _common(fn: Callable) -> Callable:
    fn = click.option(
        "--face",
        type=click.Path(dir_okay=False),
        default=None,
        help="Face JSON file (bring your own face) or glTF/VRM avatar "
        "(.glb, .gltf, .vrm); default: built-in head.",
    )(fn)
    fn = click.option(
        "--size",
        type=int,
        default=368,
        show_default=True,
        help="Pixels per face (square, a multiple of 16).",
    )(fn)
    fn = click.option(
        "--mosaic-block",
        type=int,
        default=24,
        show_default=True,
        help="Mouth mosaic block size in pixels (0: no mosaic).",
    )(fn)
    fn = click.option(
        "--samples",
        type=click.Choice(["0", "2", "4", "8"]),
        default="4",
        show_default=True,
        help="Multisample anti-aliasing samples for --antialias msaa.",
    )(fn)
    fn = click.option(
        "--antialias",
        type=click.Choice(["edges", "msaa", "none"]),
        default="edges",
        show_default=True,
        help="edges: silhouette edge overdraw (fast on a CPU); msaa: "
        "multisampling (for a GPU); none.",
    )(fn)
    fn = click.option(
        "--look",
        type=click.Choice(["textured", "plain"]),
        default="textured",
        show_default=True,
        help="The built-in head's look: textured skin, brows and lashes, or "
        "plain (per-vertex colour, the earlier head).",
    )(fn)
    return fn


def _clip_options(fn: Callable) -> Callable:
    fn = click.option(
        "--cache-dir",
        type=click.Path(file_okay=False),
        default=None,
        help="Reuse clips rendered before from this folder (content hash).",
    )(fn)
    fn = click.option(
        "--fps", type=float, default=None, help="Output frame rate (default: the track's)."
    )(fn)
    fn = click.option(
        "--pad",
        is_flag=True,
        help="Pad (holding the last frame) or cut a track whose length differs from the "
        "audio's by more than 0.2 s, instead of refusing it.",
    )(fn)
    fn = click.option(
        "--workers",
        type=int,
        default=0,
        show_default=True,
        help="Processes drawing frames (0: one per CPU core).",
    )(fn)
    return fn


@click.group()
def render() -> None:
    """Render motion tracks as face clips (H.264/AAC MP4) and stills (PNG)."""


@render.command("pair")
@click.option(
    "--left",
    required=True,
    type=_track,
    help="Track of the left face (.fap/.csv; a mesh .npy/.npz or FLAME .npz/.pkl).",
)
@click.option("--right", required=True, type=_track, help="Track of the right face.")
@click.option("--audio", required=True, type=click.Path(dir_okay=False), help="Speech audio.")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output .mp4.")
@_common
@_clip_options
@mesh_options
def pair(
    left: str,
    right: str,
    audio: str,
    out: str,
    face: str | None,
    size: int,
    mosaic_block: int,
    antialias: str,
    samples: str,
    look: str,
    fps: float | None,
    cache_dir: str | None,
    pad: bool,
    workers: int,
    template: str | None,
    mesh_fps: float | None,
    units: str,
    regions: str | None,
    flame_model: str | None,
    mesh_eyes: str,
) -> None:
    """Side-by-side clip LEFT | RIGHT over AUDIO, mouths hidden by a mosaic."""
    from renderer import render_pair

    settings = _clip_settings(size, mosaic_block, face, antialias, samples, look, fps, workers)
    mesh = mesh_settings(template, mesh_fps, units, regions, flame_model)
    loaded = {"left": _load(left, mesh), "right": _load(right, mesh)}
    _fitted_to_audio({left: loaded["left"], right: loaded["right"]}, audio, fps, pad)
    tracks = _mesh_notes(loaded, mesh_eyes)
    _face_notes(settings)
    with _progress_bar("render pair") as progress:
        path = render_pair(
            *tracks, audio, out, settings=settings, cache_dir=cache_dir, progress=progress
        )
    click.echo(f"{path}: {size * 2}x{size}, {tracks[0].n_frames} frames")


@render.command("single")
@click.option("--track", "track_path", required=True, type=_track, help="Motion track.")
@click.option("--audio", required=True, type=click.Path(dir_okay=False), help="Speech audio.")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output .mp4.")
@_common
@_clip_options
@mesh_options
def single(
    track_path: str,
    audio: str,
    out: str,
    face: str | None,
    size: int,
    mosaic_block: int,
    antialias: str,
    samples: str,
    look: str,
    fps: float | None,
    cache_dir: str | None,
    pad: bool,
    workers: int,
    template: str | None,
    mesh_fps: float | None,
    units: str,
    regions: str | None,
    flame_model: str | None,
    mesh_eyes: str,
) -> None:
    """Single-face clip of TRACK over AUDIO."""
    from renderer import render_single

    settings = _clip_settings(size, mosaic_block, face, antialias, samples, look, fps, workers)
    track = _load(track_path, mesh_settings(template, mesh_fps, units, regions, flame_model))
    _fitted_to_audio({track_path: track}, audio, fps, pad)
    (track,) = _mesh_notes({"track": track}, mesh_eyes)
    _face_notes(settings)
    with _progress_bar("render single") as progress:
        path = render_single(
            track, audio, out, settings=settings, cache_dir=cache_dir, progress=progress
        )
    click.echo(f"{path}: {size}x{size}, {track.n_frames} frames")


@render.command("still")
@click.option("--track", "track_path", required=True, type=_track, help="Motion track.")
@click.option(
    "--right",
    "right_path",
    type=_track,
    default=None,
    help="Second track: a side-by-side still (track left, this right).",
)
@click.option("--frame", type=int, default=0, show_default=True, help="Frame index.")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output .png.")
@click.option("--no-mosaic", is_flag=True, help="Show the mouth.")
@_common
@mesh_options
def still(
    track_path: str,
    right_path: str | None,
    frame: int,
    out: str,
    face: str | None,
    size: int,
    mosaic_block: int,
    antialias: str,
    samples: str,
    look: str,
    no_mosaic: bool,
    template: str | None,
    mesh_fps: float | None,
    units: str,
    regions: str | None,
    flame_model: str | None,
    mesh_eyes: str,
) -> None:
    """PNG still of frame FRAME of TRACK."""
    from renderer import render_still

    settings = _settings(
        size, mosaic_block, face, antialias=antialias, samples=int(samples), look=look
    )
    mesh = mesh_settings(template, mesh_fps, units, regions, flame_model)
    loaded = {"track": _load(track_path, mesh)}
    if right_path:
        loaded["right"] = _load(right_path, mesh)
    tracks = _mesh_notes(loaded, mesh_eyes)
    _face_notes(settings)
    path = render_still(
        tracks[0],
        frame,
        out,
        right=tracks[1] if right_path else None,
        settings=settings,
        mosaic=not no_mosaic,
    )
    click.echo(str(path))
