"""The renderer's public API: side-by-side clips, single-face clips and PNG stills.

Example
-------
>>> import numpy as np
>>> from app.stimuli.track import MotionTrack
>>> from renderer import RenderSettings, render_still
>>> track = MotionTrack.from_channels(30.0, {49: np.linspace(0, 20000, 10)})
>>> render_still(track, 9, "/tmp/facepair-doctest.png", settings=RenderSettings(size=128))
PosixPath('/tmp/facepair-doctest.png')
"""

from __future__ import annotations

import functools
import logging
import os
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import renderer.defaults as defaults
from app.errors import InputError
from app.stimuli.track import MotionTrack
from renderer.avatar import AVATAR_SUFFIXES
from renderer.cache import cache_key, cached_path, deliver
from renderer.encode import WEBM_SUFFIX, ClipWriter, check_audio
from renderer.face import Face
from renderer.gl import check_antialias
from renderer.headmodel import builtin_face, check_look
from renderer.pipeline import align_tracks, render_frames

RENDERER_VERSION = "1.6"

log = logging.getLogger(__name__)

Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class RenderSettings:
    """How clips look and are encoded.

    size : pixels per face, square, a multiple of 16.
    mosaic_block : mosaic cell size in pixels; 0 turns the mosaic off.
    mosaic_margin : the mouth box grows by this fraction of its larger side on every side.
    antialias : ``"edges"`` (discontinuity edge overdraw, Sander et al. 2001; cheap on a CPU),
        ``"msaa"`` (multisampling with ``samples`` samples; the choice on a GPU) or ``"none"``.
    samples : multisample anti-aliasing samples for ``antialias="msaa"`` (2, 4 or 8).
    fps : output frame rate; None takes the (first) track's.
    face : a face JSON file (bring your own face) or a glTF 2.0 / VRM avatar with ARKit
        blendshapes (``.glb``, ``.gltf``, ``.vrm``; see docs/reference/renderer.md); None = built-in
        head.
    background : RGB in 0..1.
    look : the built-in head's look: ``"textured"`` (skin texture, strand brows, eyelashes;
        the default) or ``"plain"`` (per-vertex colour, the head before the texture); not
        used with ``face``.

    The drawing defaults (size, mosaic, anti-aliasing, background) are those of
    :mod:`renderer.defaults`.
    crf, preset : libx264 quality (lower crf = better) and speed preset (superfast: about
        a quarter less CPU than veryfast for about twice the bytes at the same crf).
    encode_threads : libx264 threads (1, the least CPU per frame; 0 = one per core).
    audio_bitrate : AAC bit rate.
    workers : processes drawing frames for clips of 240 frames or more (0 = one per CPU core;
        1 = draw in this process). Does not change the output, so it is not part of the cache
        key.
    """

    size: int = defaults.SIZE
    mosaic_block: int = defaults.MOSAIC_BLOCK
    mosaic_margin: float = defaults.MOSAIC_MARGIN
    antialias: str = defaults.ANTIALIAS
    samples: int = defaults.SAMPLES
    fps: float | None = None
    face: str | None = None
    background: tuple[float, float, float] = defaults.BACKGROUND
    crf: int = 20
    preset: str = "superfast"
    audio_bitrate: str = "128k"
    encode_threads: int = 1
    workers: int = 0
    look: str = "textured"

    def drawing(self) -> dict[str, Any]:
        """The keyword arguments of :func:`renderer.pipeline.render_frames` these settings give."""
        return {
            "size": self.size,
            "antialias": self.antialias,
            "samples": self.samples,
            "background": self.background,
            "mosaic_block": self.mosaic_block,
            "mosaic_margin": self.mosaic_margin,
        }

    def output_fields(self) -> dict[str, Any]:
        """The settings that change the clip's bytes (the cache key's share).

        ``face`` is hashed from its content instead, ``workers`` does not change the output,
        ``samples`` counts only for multisampling, and one-per-core encoder threads are keyed
        by this machine's core count (x264's output depends on its thread count).
        """
        fields = {k: v for k, v in asdict(self).items() if k not in ("face", "workers")}
        if self.antialias != "msaa":
            del fields["samples"]
        if self.encode_threads == 0:
            fields["encode_threads"] = f"auto:{os.cpu_count()}"
        return fields

    def __post_init__(self) -> None:
        if not isinstance(self.size, int) or self.size < 64 or self.size % 16:
            raise InputError(
                f"must be a multiple of 16 and at least 64, got {self.size!r}", field="size"
            )
        if not isinstance(self.mosaic_block, int) or self.mosaic_block < 0:
            raise InputError(
                f"must be a whole number of pixels >= 0, got {self.mosaic_block!r}",
                field="mosaic_block",
            )
        if self.mosaic_block > self.size // 2:
            raise InputError(
                f"must be at most half the face size ({self.size // 2}), got {self.mosaic_block}",
                field="mosaic_block",
            )
        if not 0 <= self.mosaic_margin <= 2:
            raise InputError(f"must be in 0..2, got {self.mosaic_margin!r}", field="mosaic_margin")
        check_antialias(self.antialias)
        if self.samples not in (0, 1, 2, 4, 8):
            raise InputError(f"must be 0, 1, 2, 4 or 8, got {self.samples!r}", field="samples")
        if type(self.workers) is not int or self.workers < 0:
            raise InputError(f"must be a whole number >= 0, got {self.workers!r}", field="workers")
        if type(self.encode_threads) is not int or self.encode_threads < 0:
            raise InputError(
                f"must be a whole number >= 0, got {self.encode_threads!r}", field="encode_threads"
            )
        if self.fps is not None and not self.fps > 0:
            raise InputError(f"must be positive, got {self.fps!r}", field="fps")
        check_look(self.look)


def load_face(settings: RenderSettings) -> Face:
    """The face the settings name: a face JSON file, a glTF / VRM avatar, or the built-in
    head. A file is read once while it (and an avatar's sidecar) stays as it is: a study
    renders every clip with one avatar, which may take a second to read."""
    if settings.face is None:
        return builtin_face(settings.look)
    path = Path(settings.face)
    stamps: list[tuple[int, int] | None] = []
    for p in (path, path.with_name(path.stem + ".avatar.json")):
        try:
            stat = p.stat()
            stamps.append((stat.st_mtime_ns, stat.st_size))
        except OSError:
            stamps.append(None)
    return _read_face(str(path.resolve()), tuple(stamps))


def load_faces(
    tracks: list[MotionTrack], settings: RenderSettings, audio_path: str | Path | None = None
) -> list[Face]:
    """The face of each track: a mesh condition's own (:mod:`renderer.meshface`; its lips
    found from the motion that follows ``audio_path``'s energy where no region file names
    them), else the face the settings name (:func:`load_face`)."""
    from app.stimuli.meshes.source import mesh_of

    faces: list[Face] = []
    for track in tracks:
        seq = mesh_of(track)
        if seq is None:
            faces.append(load_face(settings))
            continue
        audio = str(Path(audio_path).resolve()) if audio_path is not None else None
        faces.append(_mesh_face(seq.digest(), seq, audio))
    return faces


@functools.lru_cache(maxsize=4)
def _mesh_face(_digest: str, seq: Any, audio: str | None) -> Face:
    from app.stimuli.meshes.regions import speech_energy
    from renderer.meshface import mesh_face

    energy = None
    if audio is not None and seq.lips is None:
        energy = speech_energy(audio, seq.fps, seq.n_frames)
    return mesh_face(seq, energy)


def faces_hash(faces: list[Face], tracks: list[MotionTrack]) -> str:
    """The faces' share of the cache key: the face's hash when every track has the same (as
    before meshes), else each face's with the offset a mesh's frames are read at."""
    hashes = [f.content_hash() for f in faces]
    if len(set(hashes)) == 1 and not any("mesh" in t.metadata for t in tracks):
        return hashes[0]
    offsets = [t.metadata.get("offset_s", 0.0) for t in tracks]
    return "|".join(f"{h}@{o!r}" for h, o in zip(hashes, offsets, strict=True))


@functools.lru_cache(maxsize=2)
def _read_face(path: str, _stamps: tuple) -> Face:
    if Path(path).suffix.lower() in AVATAR_SUFFIXES:
        from renderer.avatar import load_avatar

        return load_avatar(path)
    from renderer.objface import load_face as load_face_file

    return load_face_file(path)


def _render_clip(
    kind: str,
    tracks: list[MotionTrack],
    audio_path: str | Path | None,
    out_path: str | Path,
    settings: RenderSettings | None,
    cache_dir: str | Path | None,
    progress: Progress | None,
    caption: str | None = None,
    webm_path: str | Path | None = None,
) -> Path:
    settings = settings or RenderSettings()
    stamp = None
    if caption:
        from renderer.caption import CaptionStamp

        stamp = CaptionStamp(caption, width=settings.size * len(tracks), height=settings.size)
        kind = f"{kind}+caption:{caption}"
    audio = check_audio(audio_path)
    tracks = align_tracks(tracks, settings.fps)
    faces = load_faces(tracks, settings, audio)
    out = Path(out_path)
    webm = Path(webm_path) if webm_path is not None else None
    target, webm_target = out, webm
    if cache_dir is not None:
        key = cache_key(kind, tracks, audio, faces_hash(faces, tracks), settings, RENDERER_VERSION)
        target = cached_path(cache_dir, key, ".mp4")
        # the WebM's encoder settings are constants of renderer.encode: they name its entry
        webm_target = cached_path(cache_dir, key, WEBM_SUFFIX) if webm is not None else None
        if target.is_file() and (webm_target is None or webm_target.is_file()):
            if progress:
                progress(tracks[0].n_frames, tracks[0].n_frames)
            if webm is not None and webm_target is not None:
                deliver(webm_target, webm)
            return deliver(target, out)
        target.parent.mkdir(parents=True, exist_ok=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    if webm is not None:
        webm.parent.mkdir(parents=True, exist_ok=True)
    n = tracks[0].n_frames
    partial = target.with_name(target.stem + ".part.mp4")
    webm_partial = (
        webm_target.with_name(webm_target.stem + ".part.webm") if webm_target is not None else None
    )
    devices: list[str] = []
    frames = render_frames(
        tracks,
        faces,
        **settings.drawing(),
        workers=settings.workers or os.cpu_count() or 1,
        on_device=devices.append,
    )
    with ClipWriter(
        partial,
        settings.size * len(tracks),
        settings.size,
        tracks[0].fps,
        n,
        audio,
        crf=settings.crf,
        preset=settings.preset,
        audio_bitrate=settings.audio_bitrate,
        threads=settings.encode_threads,
        webm_path=webm_partial,
    ) as writer:
        for frame in frames:
            writer.write(frame.image if stamp is None else stamp(frame.image))
            if progress:
                progress(frame.index + 1, n)
    partial.replace(target)
    if webm is not None and webm_partial is not None and webm_target is not None:
        webm_partial.replace(webm_target)
        if webm_target != webm:
            deliver(webm_target, webm)
    log.info(
        "%s clip %s: %d frames of %d px drawn on %s",
        kind,
        out,
        n,
        settings.size,
        devices[0] if devices else "no device",
    )
    return deliver(target, out) if target != out else out


def render_pair(
    left: MotionTrack,
    right: MotionTrack,
    audio_path: str | Path | None,
    out_path: str | Path,
    *,
    settings: RenderSettings | None = None,
    cache_dir: str | Path | None = None,
    progress: Progress | None = None,
    caption: str | None = None,
    webm_path: str | Path | None = None,
) -> Path:
    """Render ``left`` | ``right`` side by side over ``audio_path`` into an MP4.

    Both faces come from the same timeline, frame for frame; swap the arguments for B|A.
    The clip has the first track's length and frame rate (``settings.fps`` overrides; the
    other track is resampled and padded or trimmed to it); the audio is padded or trimmed to
    the clip. With ``cache_dir`` the clip is looked up by content hash and rendered only once.
    ``progress(done, total)`` is called after each frame. ``caption`` is drawn across the top
    of every frame (:mod:`renderer.caption`: an attention check's "PRESS LEFT"). With
    ``webm_path`` the same frames are also written there as the WebM rendition (VP9 + Opus,
    :mod:`renderer.encode`), for browsers without H.264. Returns ``out_path``.
    """
    return _render_clip(
        "pair",
        [left, right],
        audio_path,
        out_path,
        settings,
        cache_dir,
        progress,
        caption,
        webm_path,
    )


def render_single(
    track: MotionTrack,
    audio_path: str | Path | None,
    out_path: str | Path,
    *,
    settings: RenderSettings | None = None,
    cache_dir: str | Path | None = None,
    progress: Progress | None = None,
    webm_path: str | Path | None = None,
) -> Path:
    """Render one face over ``audio_path`` into an MP4 (and ``webm_path``'s WebM rendition,
    as :func:`render_pair`)."""
    return _render_clip(
        "single", [track], audio_path, out_path, settings, cache_dir, progress, None, webm_path
    )


def render_still(
    track: MotionTrack,
    frame: int,
    out_path: str | Path,
    *,
    right: MotionTrack | None = None,
    settings: RenderSettings | None = None,
    mosaic: bool = True,
) -> Path:
    """Write frame ``frame`` of ``track`` (and of ``right`` beside it, if given) as a PNG.

    ``mosaic=False`` shows the mouth (for previews of the face itself).
    """
    import imageio.v3 as iio

    settings = settings or RenderSettings()
    tracks = align_tracks([track] + ([right] if right is not None else []), settings.fps)
    n = tracks[0].n_frames
    if not isinstance(frame, int) or not 0 <= frame < n:
        raise InputError(f"must be a frame index in 0..{n - 1}, got {frame!r}", field="frame")
    faces = load_faces(tracks, settings)
    drawing = settings.drawing()
    if not mosaic:
        drawing["mosaic_block"] = 0
    rendered = next(render_frames(tracks, faces, **drawing, frames=range(frame, frame + 1)))
    out = Path(out_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(out, rendered.image.copy())
    return out
