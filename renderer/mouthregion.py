"""The region of the head a clip's mouth moves through: what the mouth mosaic must cover.

A mosaic over the lips alone leaves the lower face's motion in view: the chin and the jaw's
outline below the blocks move with FAP 3, and lip-sync reads from them in every condition.
:func:`motion_envelope` bounds, once per clip, every surface point the clip's jaw and lip
FAPs can move, from the clip's own tracks (both faces of a pair together, so both get the
same region of the head): per vertex an axis-aligned box in the face's own frame holding

* the jaw's arc, sampled every :data:`JAW_STEP` of the widest opening (FAP 3) the tracks
  reach, plus the largest bulge of the arc between two samples;
* plus the interval sum of the displacement of every other jaw and lip FAP between the
  smallest and the largest value the tracks give it (the lips move linearly in their FAPs,
  :mod:`renderer.deform`; an interval sum bounds any mix of them),
* grown by how far the jaw's turn can swing the lips' displacement (``2 |d| sin(a / 2)``),

for every vertex whose position or normal any of those FAPs changes (beyond the rig's
tolerances, and below its ceiling: an avatar's sculpted shapes move skin up to the brows by
fractions of a pixel, :class:`renderer.deform.Rig`), and the rest positions of the other
corners of their triangles (a triangle's pixels lie in the hull of its corners). The boxes'
corners are cut down to their convex hull. Per frame the envelope is posed with the frame's
head turn and projected (:meth:`MotionEnvelope.pixels`); the mosaic's box holds those pixels
(:func:`renderer.mosaic.mouth_box`), so no pixel outside its blocks depends on the jaw or the
lips. The blocks never cover the eyes, lids and brows (:func:`upper_face`): a gaze, blink or
brow study must show them, and the face under the blocks is drawn with its mouth at rest.

Example
-------
>>> import numpy as np
>>> from renderer.deform import Rig
>>> from renderer.headmodel import builtin_face
>>> rig = Rig(builtin_face())
>>> jaw = np.zeros((4, 68)); jaw[:, 2] = [0, 100, 350, 200]
>>> env = motion_envelope(rig, [jaw])
>>> bool(env.points[:, 1].min() < rig.face.feature_points["2.1"][1])  # below the chin at rest
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.stimuli.fap import N_FAPS, OPEN_JAW
from renderer.deform import MOUTH_FAPS, FaceFrame, Rig

#: The jaw's arc is sampled every this many radians of its opening.
JAW_STEP = np.radians(3.0)


@dataclass(frozen=True)
class MotionEnvelope:
    """Points whose hull holds everything a clip's mouth moves, in the face's own frame.

    ``points`` (k, 3) before the head turn, ``head`` (k,) each point's head weight (how far
    it follows the head's turn, as :meth:`renderer.deform.Rig.posed` blends it).
    """

    points: np.ndarray
    head: np.ndarray

    def world(self, frame: FaceFrame) -> np.ndarray:
        """The points posed with ``frame``'s head turn, (k, 3)."""
        turned = self.points @ frame.head[:3, :3].T + frame.head[:3, 3]
        return self.points + self.head[:, None] * (turned - self.points)


def motion_envelope(rig: Rig, dense: list[np.ndarray]) -> MotionEnvelope:
    """The envelope of the jaw and lip motion of ``dense`` tracks ((n, 68) FAP values each)
    on ``rig``'s face: see the module's docstring for what it bounds and how."""
    values = np.vstack([np.asarray(d, dtype=np.float64) for d in dense])
    faps = np.array(MOUTH_FAPS)
    lo = np.minimum(values[:, faps - 1].min(axis=0, initial=0.0), 0.0)
    hi = np.maximum(values[:, faps - 1].max(axis=0, initial=0.0), 0.0)
    zero = np.zeros(N_FAPS)
    rest = rig.deform(zero)
    p0, n0 = rest.positions.astype(np.float64), rest.normals
    changed = np.zeros(len(p0), bool)

    def deformed(fap: int, value: float) -> np.ndarray:
        f = zero.copy()
        f[fap - 1] = value
        frame = rig.deform(f)
        moved = np.abs(frame.positions - rest.positions).max(axis=1) > rig.motion_tolerance
        turned = np.abs(frame.normals - n0).max(axis=1) > rig.normal_tolerance
        changed[moved | turned] = True
        return frame.positions.astype(np.float64)

    # the jaw's arc; its widest turn bounds how far it swings the lips' displacement
    jaw_hi = float(hi[faps == OPEN_JAW][0])
    per_unit = float(getattr(rig, "jaw_rad_per_unit", 0.0))
    turn = jaw_hi * per_unit
    n_jaw = max(2, int(np.ceil(turn / JAW_STEP)) + 1)
    arc = [p0] + [deformed(OPEN_JAW, v) for v in np.linspace(0.0, jaw_hi, n_jaw)[1:]]
    box_lo, box_hi = np.min(arc, axis=0), np.max(arc, axis=0)
    reach = np.linalg.norm(p0 - rig.hinge, axis=1) if turn else np.zeros(len(p0))
    bulge = reach * (1.0 - np.cos(turn / (n_jaw - 1) / 2.0))
    # every other jaw and lip FAP: linear, so an interval sum bounds any mix of them
    d_lo, d_hi = np.zeros_like(p0), np.zeros_like(p0)
    for fap, a, b in zip(faps, lo, hi, strict=True):
        if fap == OPEN_JAW:
            continue
        for value in {float(a), float(b)} - {0.0}:
            d = deformed(int(fap), value) - p0
            d_lo += np.minimum(d, 0.0)
            d_hi += np.maximum(d, 0.0)
    swing = np.linalg.norm(np.maximum(-d_lo, d_hi), axis=1) * 2.0 * np.sin(turn / 2.0)
    grow = (bulge + swing)[:, None]
    box_lo, box_hi = box_lo + d_lo - grow, box_hi + d_hi + grow

    if rig.mouth_ceiling is not None:
        changed &= p0[:, 1] <= rig.mouth_ceiling
    triangles = rig.face.triangles
    touched = changed[triangles].any(axis=1)
    corners = np.zeros(len(p0), bool)
    corners[triangles[touched].ravel()] = True
    still = corners & ~changed
    moving = np.flatnonzero(changed)
    pick = np.array([[(k >> a) & 1 for a in range(3)] for k in range(8)], bool)  # box corners
    boxes = np.where(pick[None], box_hi[moving][:, None], box_lo[moving][:, None])
    points = np.vstack([boxes.reshape(-1, 3), p0[still]])
    head_w = np.asarray(rig.weights["head"], dtype=np.float64)
    weights = np.concatenate([np.repeat(head_w[moving], 8), head_w[still]])
    return _hull(points, weights)


def _hull(points: np.ndarray, weights: np.ndarray) -> MotionEnvelope:
    """Keep, among the points of each head weight, the corners of their convex hull (the
    projection of a convex set is the projection of its corners)."""
    from scipy.spatial import ConvexHull, QhullError

    keep = []
    for w in np.unique(weights):
        idx = np.flatnonzero(weights == w)
        if len(idx) > 8:
            try:
                idx = idx[ConvexHull(points[idx]).vertices]
            except QhullError:  # flat or degenerate: keep them all
                pass
        keep.append(idx)
    kept = np.concatenate(keep) if keep else np.zeros(0, int)
    return MotionEnvelope(points[kept], weights[kept])


#: FAP values that show where the brows and lids are: the brows raised, the lids closed.
UPPER_FACE_FAPS = {31: 100.0, 32: 100.0, 33: 100.0, 34: 100.0, 35: 100.0, 36: 100.0}
UPPER_FACE_FAPS |= {19: 1024.0, 20: 1024.0, 21: 1024.0, 22: 1024.0}


def upper_face(rig: Rig, share: float = 0.25) -> np.ndarray:
    """The vertices the mosaic must never cover: the eyeballs, and what raising the brows and
    closing the lids moves by at least ``share`` of its largest motion (the brows and lids
    themselves, not the forehead's faint stretch)."""
    zero = np.zeros(N_FAPS)
    moving = zero.copy()
    for fap, value in UPPER_FACE_FAPS.items():
        moving[fap - 1] = value
    rest, moved = rig.deform(zero).positions, rig.deform(moving).positions
    d = np.linalg.norm(moved.astype(np.float64) - rest, axis=1)
    near = np.flatnonzero(d >= share * d.max()) if d.max() > 0 else np.zeros(0, int)
    eyes = [np.asarray(rig.eye_vertices[s], dtype=int) for s in ("l", "r")]
    return np.unique(np.concatenate([near, *eyes]))
