"""Frame generation: tracks -> deformed faces -> one GL draw per frame -> mouth mosaic.

Both faces of a pair are drawn from the same frame index of the same timeline into one
framebuffer, so they are frame-exact by construction; the side order is the order of the tracks.

With ``workers`` > 1 and enough frames, the frames are drawn by that many worker processes (each
with its own headless GL context; spawned, never forked, as GL state does not survive a fork) in
chunks of consecutive frames, a bounded number of chunks ahead, and yielded in order. On a CPU
rasteriser one process cannot keep two cores busy (Mesa's vertex stage runs on the submitting
thread), so this is what lets rendering and encoding share the machine.
"""

from __future__ import annotations

import multiprocessing
import os
from collections import deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import lru_cache
from multiprocessing import shared_memory
from typing import Any

import numpy as np

import renderer.defaults as defaults
from app.errors import InputError
from app.stimuli.track import MotionTrack
from renderer.avatar import AvatarFace, AvatarRig
from renderer.camera import project
from renderer.deform import MOUTH_FAPS_INDEX, FaceFrame, Rig
from renderer.face import MOUTH_FEATURE_POINTS, Face
from renderer.faceregions import face_envelopes, mesh_frames_of, never_covered
from renderer.gl import FaceCanvas, device_name
from renderer.meshface import MeshFace, MeshRig
from renderer.mosaic import cells_meeting, mouth_box, pixelate_face
from renderer.mouthregion import MotionEnvelope


@dataclass
class RenderedFrame:
    """One output frame and, per face (left to right), its mosaic: the box in frame pixels
    and which of the box's cells are blocks (rows, columns of cells; the others are the
    frame as drawn)."""

    index: int
    image: np.ndarray  # (H, W, 3) uint8, reused between frames: copy to keep
    boxes: list[tuple[int, int, int, int]]
    cells: list[np.ndarray] = field(default_factory=list)


@lru_cache(maxsize=4)
def _rig_for(face_key: str, face: Face) -> Rig:
    if isinstance(face, MeshFace):
        return MeshRig(face)
    if isinstance(face, AvatarFace):
        return AvatarRig(face)
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


#: Pixels the mosaic reaches past the region the mouth moves through: the edge overdraw's
#: strip (one pixel outside a silhouette, :mod:`renderer.edges`) and a pixel of rounding.
ENVELOPE_PAD = 2.0

#: Fewer frames than this are drawn in-process: starting a worker costs about a second.
PARALLEL_MIN_FRAMES = 240
CHUNK_FRAMES = 6


class _Drawer:
    """Draws frames of fixed tracks: deform (or take a mesh's frame), GL draw, mouth mosaic.

    With the mosaic, each face is drawn with its mouth at rest (the jaw and lip FAPs at zero; a
    mesh's lower face taken back to its template, :mod:`renderer.meshface`) and the box covers
    everything the clip's mouth moves (:mod:`renderer.mouthregion`, :mod:`renderer.meshmosaic`):
    the pixels outside it are those of the moving mouth's drawing, and the blocks inside take
    their colours from the mouth at rest, so nothing of the mouth's motion shows, one drawing a
    face. Faces of one kind share a canvas; a pair of different faces (a mesh beside the
    built-in head) has one per face, each framed on its own face.
    """

    def __init__(
        self,
        dense: list[np.ndarray],
        faces: list[Face],
        size: int,
        antialias: str,
        samples: int,
        background: tuple[float, float, float],
        mosaic_block: int | None,
        mosaic_margin: float,
        envelopes: list[MotionEnvelope] | None = None,
        mesh_frames: list[np.ndarray | None] | None = None,
    ) -> None:
        self.dense, self.size, self.faces = dense, size, faces
        self.rigs = [rig_for(f) for f in faces]
        self.mesh_frames = mesh_frames or [None] * len(faces)
        self.mosaic_block, self.mosaic_margin = mosaic_block, mosaic_margin
        if mosaic_block and envelopes is None:
            envelopes = face_envelopes(faces, self.rigs, dense, self.mesh_frames)
        self.envelopes: list[MotionEnvelope | None] = (
            list(envelopes) if envelopes else [None] * len(faces)
        )
        self.upper = [never_covered(rig) if mosaic_block else np.zeros(0, int) for rig in self.rigs]
        groups: dict[str, list[int]] = {}
        for k, face in enumerate(faces):
            groups.setdefault(face.content_hash(), []).append(k)
        self.groups = list(groups.values())
        self.canvases = [
            FaceCanvas(
                self.rigs[g[0]],
                size,
                len(g),
                antialias=antialias,
                samples=samples,
                background=background,
            )
            for g in self.groups
        ]
        self.canvas_of = {k: c for g, c in zip(self.groups, self.canvases, strict=True) for k in g}
        self.buffer = np.empty((size, size * len(faces), 3), np.uint8)
        self.background_u8 = self.canvases[0].background_u8

    @property
    def canvas(self) -> FaceCanvas:
        """The canvas of the first face (all faces' when they are of one kind)."""
        return self.canvases[0]

    def face_frame(self, k: int, i: int, at_rest: bool) -> FaceFrame:
        """Frame ``i`` of face ``k``, its mouth at rest with ``at_rest``."""
        rig, faps = self.rigs[k], self.dense[k][i]
        frames = self.mesh_frames[k]
        if frames is not None:
            assert isinstance(rig, MeshRig)
            positions = rig.at_rest(frames[i]) if at_rest else frames[i]
            return rig.frame(positions, faps)
        if at_rest:
            faps = faps.copy()
            faps[MOUTH_FAPS_INDEX] = 0.0
        return rig.deform(faps)

    def draw(self, i: int, out: np.ndarray | None = None) -> RenderedFrame:
        block = self.mosaic_block
        single = len(self.canvases) == 1
        if out is None:
            out = self.canvas.buffer if single else self.buffer
        frames = [self.face_frame(k, i, bool(block)) for k in range(len(self.faces))]
        for g, canvas in zip(self.groups, self.canvases, strict=True):
            canvas.draw(
                [frames[k] for k in g], out, lips_closed=bool(block), slots=None if single else g
            )
        if not block:
            return RenderedFrame(i, out, [])
        boxes, masks = [], []
        for k, frame in enumerate(frames):
            (x0, y0, x1, y1), cells = self.mosaic_cells(frame, k)
            box = (x0 + k * self.size, y0, x1 + k * self.size, y1)
            pixelate_face(out, box, block, self.background_u8, cells)
            boxes.append(box)
            masks.append(cells)
        return RenderedFrame(i, out, boxes, masks)

    def mosaic_cells(
        self, frame: FaceFrame, k: int = 0
    ) -> tuple[tuple[int, int, int, int], np.ndarray]:
        """The mosaic in face ``k``'s pixels: its box and its cells (rows, columns; True for a
        block). The blocks are the cells of the mouth at rest grown by the margin, and the
        cells that meet the region the clip's mouth moves through (its envelope, posed
        as ``frame``, grown by :data:`ENVELOPE_PAD`): a tilted or turned head's mosaic follows
        its lower face instead of filling a box up to the eyes."""
        envelope, block = self.envelopes[k], self.mosaic_block
        assert envelope is not None and block
        vp, size, rig = self.canvas_of[k].vp, self.size, self.rigs[k]
        mouth = project(vp, rig.world_points(frame, MOUTH_FEATURE_POINTS), size)
        moves = project(vp, envelope.world(frame), size)
        margin = self.mosaic_margin
        box = mouth_box(
            mouth, size, size, block=block, margin=margin, cover=moves, pad=ENVELOPE_PAD
        )
        lips = mouth_box(mouth, size, size, block=block, margin=margin)
        x0, y0 = box[:2]
        cells = cells_meeting(moves, box, block, ENVELOPE_PAD)
        rows = slice((lips[1] - y0) // block, (lips[3] - y0) // block)
        cols = slice((lips[0] - x0) // block, (lips[2] - x0) // block)
        cells[rows, cols] = True
        # never over the eyes and brows: a turned and pitched head brings the blocks the
        # envelope meets up to the lids and the brows' inner ends, and a gaze, blink or brow
        # study must show them (the face is drawn with its mouth at rest, so a block left out
        # shows no mouth motion)
        for px, py in self.upper_face_pixels(frame, k):
            r0, r1 = int((py - 1.0 - y0) // block), int((py + 1.0 - y0) // block)
            c0, c1 = int((px - 1.0 - x0) // block), int((px + 1.0 - x0) // block)
            cells[max(r0, 0) : max(r1 + 1, 0), max(c0, 0) : max(c1 + 1, 0)] = False
        return box, cells

    def upper_face_pixels(self, frame: FaceFrame, k: int = 0) -> np.ndarray:
        """The pixels (x, y) of face ``k``'s eyes, lids and brows (:func:`upper_face`) in
        ``frame``'s pose (the head turned; the eyes' own turns and the brows' motion stay
        within the cells these reach)."""
        idx = self.upper[k]
        p = frame.positions[idx].astype(np.float64)
        turned = p @ frame.head[:3, :3].T + frame.head[:3, 3]
        p = p + self.rigs[k].weights["head"][idx][:, None] * (turned - p)
        return project(self.canvas_of[k].vp, p, self.size)

    def release(self) -> None:
        for canvas in self.canvases:
            canvas.release()


_WORKER: dict[str, Any] = {}

#: The thread-count variables of the BLAS libraries numpy may load, read once when it loads.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


@contextmanager
def _single_threaded_blas() -> Iterator[None]:
    """Worker processes started inside this block load their BLAS with one thread.

    A worker's matrix products are (n, 3) by (3, 3); a BLAS thread pool gains nothing on them
    and its idle threads spin on the cores the other worker and the encoder need. A variable
    the user set is kept.
    """
    added = [v for v in BLAS_THREAD_VARIABLES if v not in os.environ]
    for v in added:
        os.environ[v] = "1"
    try:
        yield
    finally:
        for v in added:
            os.environ.pop(v, None)


def _worker_start(args: tuple, ring_name: str, ring_shape: tuple[int, ...]) -> None:
    # llvmpipe's rasteriser threads only add switching when every core already runs a worker;
    # read when the GL context is made, so set before it
    os.environ.setdefault("LP_NUM_THREADS", "0")
    _WORKER["drawer"] = _Drawer(*args)
    _WORKER["shm"] = shm = shared_memory.SharedMemory(name=ring_name)
    _WORKER["ring"] = np.ndarray(ring_shape, np.uint8, buffer=shm.buf)


def _worker_draw(jobs: list[tuple[int, int]]) -> list[tuple[int, int, list, list]]:
    """Draw frames ``(index, slot)`` into their ring slots; returns ``(index, slot, boxes,
    cells)``."""
    drawer, ring = _WORKER["drawer"], _WORKER["ring"]
    out = []
    for i, slot in jobs:
        frame = drawer.draw(i, ring[slot])
        out.append((i, slot, frame.boxes, frame.cells))
    return out


def render_frames(
    tracks: list[MotionTrack],
    face: Face | list[Face],
    *,
    size: int,
    antialias: str = defaults.ANTIALIAS,
    samples: int = defaults.SAMPLES,
    background: tuple[float, float, float] = defaults.BACKGROUND,
    mosaic_block: int | None = defaults.MOSAIC_BLOCK,
    mosaic_margin: float = defaults.MOSAIC_MARGIN,
    frames: range | None = None,
    workers: int = 1,
    on_device: Callable[[str], None] | None = None,
) -> Iterator[RenderedFrame]:
    """Yield the side-by-side frames of ``tracks`` (one face per track, left to right).

    ``face``: the face of every track, or one per track (a mesh condition's is its
    :class:`renderer.meshface.MeshFace`, whose frames are read at the track's times:
    :func:`app.stimuli.meshes.sequence.sample`, after the ``offset_s`` its alignment recorded).
    ``antialias`` and ``samples``: see :class:`renderer.gl.FaceCanvas`. ``mosaic_block`` None
    or 0 leaves the mouth visible. ``frames`` picks frame indices
    (default: all). The tracks must share frame rate and length (see :func:`align_tracks`).
    ``workers`` > 1 draws in that many processes when there are at least
    :data:`PARALLEL_MIN_FRAMES` frames; the frames are the same either way.
    ``on_device(name)`` is called once, before the first frame, with the GL_RENDERER string
    of the device that draws them (a worker's, when workers draw).
    """
    faces = list(face) if isinstance(face, list) else [face] * len(tracks)
    if len(faces) != len(tracks):
        raise ValueError(f"{len(faces)} faces for {len(tracks)} tracks")
    dense = [t.dense() for t in tracks]
    mesh_frames = [mesh_frames_of(t, f) for t, f in zip(tracks, faces, strict=True)]
    indices = list(frames if frames is not None else range(tracks[0].n_frames))
    # the region the mouth moves through, from the whole clip's tracks (frames picks a part)
    rigs = [rig_for(f) for f in faces]
    envelopes = face_envelopes(faces, rigs, dense, mesh_frames) if mosaic_block else None
    args = (
        dense,
        faces,
        size,
        antialias,
        samples,
        background,
        mosaic_block,
        mosaic_margin,
        envelopes,
        mesh_frames,
    )
    if workers > 1 and len(indices) >= PARALLEL_MIN_FRAMES:
        yield from _render_parallel(
            args, indices, workers, (size, size * len(tracks), 3), on_device
        )
        return
    drawer = _Drawer(*args)
    if on_device is not None:
        on_device(device_name())
    try:
        for i in indices:
            yield drawer.draw(i)
    finally:
        drawer.release()


#: Upper bound of the shared frame ring (bytes; at least two frames); Docker's default /dev/shm
#: is 64 MiB.
RING_BYTES = 32 * 2**20


def _worker_device() -> str:
    """The GL_RENDERER string of a worker's context."""
    return device_name()


def _render_parallel(
    args: tuple,
    indices: list[int],
    workers: int,
    shape: tuple[int, int, int],
    on_device: Callable[[str], None] | None = None,
) -> Iterator[RenderedFrame]:
    """Frames drawn by ``workers`` processes, yielded in order.

    Frames come back through a shared-memory ring rather than pickled through a pipe (two
    copies of every frame fewer in this process). At most ``ahead`` chunks are in flight beyond
    the one being yielded, so a ring of ``ahead + 1`` chunks never overwrites a frame before
    the consumer has moved past it. ``ahead`` is ``2 * workers`` unless the ring would outgrow
    :data:`RING_BYTES` (then fewer chunks, and at most that many workers). Each frame is copied
    out of the ring into one reused array, so a frame kept past the generator's end is stale,
    as on the in-process path, but never points into freed shared memory.
    """
    frame_bytes = int(np.prod(shape))
    chunk = max(1, min(CHUNK_FRAMES, RING_BYTES // ((2 * workers + 1) * frame_bytes)))
    ahead = max(1, min(2 * workers, RING_BYTES // (chunk * frame_bytes) - 1))
    workers = min(workers, ahead)
    n_slots = (ahead + 1) * chunk
    ring_shape = (n_slots, *shape)
    image = np.empty(shape, np.uint8)
    shm = shared_memory.SharedMemory(create=True, size=n_slots * frame_bytes)
    try:
        ring = np.ndarray(ring_shape, np.uint8, buffer=shm.buf)
        jobs = [(i, p % n_slots) for p, i in enumerate(indices)]
        chunks = [jobs[k : k + chunk] for k in range(0, len(jobs), chunk)]
        ctx = multiprocessing.get_context("spawn")
        with _single_threaded_blas():  # read by each worker as it starts
            pool = ctx.Pool(
                workers, initializer=_worker_start, initargs=(args, shm.name, ring_shape)
            )
        with pool:
            if on_device is not None:  # every worker makes the same choice of device
                on_device(pool.apply(_worker_device))
            pending: deque = deque()
            todo = iter(chunks)
            for job in todo:
                pending.append(pool.apply_async(_worker_draw, (job,)))
                if len(pending) >= ahead:
                    break
            while pending:
                done = pending.popleft().get()
                nxt = next(todo, None)
                if nxt is not None:
                    pending.append(pool.apply_async(_worker_draw, (nxt,)))
                for i, slot, boxes, cells in done:
                    np.copyto(image, ring[slot])
                    yield RenderedFrame(i, image, boxes, cells)
        del ring
    finally:
        shm.close()
        shm.unlink()
