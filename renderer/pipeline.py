"""Frame generation: tracks -> deformed faces -> one GL draw per frame -> mouth mosaic.

Both faces of a pair are drawn from the same frame index of the same timeline into one
framebuffer, so they are frame-exact by construction; the side order is the order of the tracks.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from app.errors import InputError
from app.stimuli.track import MotionTrack
from renderer.deform import Rig
from renderer.face import MOUTH_FEATURE_POINTS, Face
from renderer.gl import FaceCanvas, project
from renderer.mosaic import mouth_box, pixelate


@dataclass
class RenderedFrame:
    """One output frame and, per face (left to right), its mosaic box in frame pixels."""

    index: int
    image: np.ndarray  # (H, W, 3) uint8, reused between frames: copy to keep
    boxes: list[tuple[int, int, int, int]]


@lru_cache(maxsize=4)
def _rig_for(face_key: str, face: Face) -> Rig:
    return Rig(face)


def rig_for(face: Face) -> Rig:
    """The (cached) rig of a face."""
    return _rig_for(face.content_hash(), face)


def align_tracks(tracks: list[MotionTrack], fps: float | None) -> list[MotionTrack]:
    """Bring tracks to one frame rate (``fps``, else the first track's) and the first's length."""
    if not tracks:
        raise InputError("no motion track given")
    target = float(fps) if fps else tracks[0].fps
    out = [t if t.fps == target else t.resample(target) for t in tracks]
    n = out[0].n_frames
    if n == 0:
        raise InputError("motion track has no frames", field=tracks[0].name or None)
    return [t if t.n_frames == n else t.fit_length(n) for t in out]


def render_frames(tracks: list[MotionTrack], face: Face, *, size: int, samples: int,
                  background: tuple[float, float, float], mosaic_block: int | None,
                  mosaic_margin: float, frames: range | None = None) -> Iterator[RenderedFrame]:
    """Yield the side-by-side frames of ``tracks`` (one face per track, left to right).

    ``mosaic_block`` None or 0 leaves the mouth visible. ``frames`` picks frame indices
    (default: all). The tracks must share frame rate and length (see :func:`align_tracks`).
    """
    rig = rig_for(face)
    dense = [t.dense() for t in tracks]
    canvas = FaceCanvas(rig, size, len(tracks), samples=samples, background=background)
    try:
        for i in frames if frames is not None else range(tracks[0].n_frames):
            deformed = [rig.deform(d[i]) for d in dense]
            image = canvas.draw(deformed)
            boxes = []
            if mosaic_block:
                for k, frame in enumerate(deformed):
                    pts = project(canvas.vp, rig.world_points(frame, MOUTH_FEATURE_POINTS), size)
                    x0, y0, x1, y1 = mouth_box(pts, size, size, block=mosaic_block,
                                               margin=mosaic_margin)
                    box = (x0 + k * size, y0, x1 + k * size, y1)
                    pixelate(image, box, mosaic_block)
                    boxes.append(box)
            yield RenderedFrame(i, image, boxes)
    finally:
        canvas.release()
