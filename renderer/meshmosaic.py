"""The region a mesh sequence's mouth moves through: what its mosaic covers.

A mesh face is drawn with its mouth at rest (:meth:`renderer.meshface.MeshRig.at_rest`): the
lower face's own motion taken back to the template. The pixels that drawing changes, against
the frame as the file gives it, are those of the triangles with a corner that moves between the
two, or whose shading changes because a neighbour moved: the triangles touching the one-ring of
the vertices that move by more than :data:`MOTION_TOLERANCE` of the eye distance in some frame.
:func:`mesh_envelope` bounds them, as :func:`renderer.mouthregion.motion_envelope` does a FAP
face's: per corner of those triangles the box of every position it takes in the clip, moving
and at rest, the boxes' corners cut down to their convex hull; posed per frame with the head's
turn and projected, the mosaic's cells cover them (:mod:`renderer.pipeline`), so no pixel outside
its blocks follows the lips or the jaw.

Example
-------
>>> import numpy as np
>>> from renderer.mouthregion import MotionEnvelope
>>> MotionEnvelope(np.zeros((0, 3)), np.zeros(0)).points.shape
(0, 3)
"""

from __future__ import annotations

import numpy as np

from renderer.meshface import MeshRig
from renderer.mouthregion import MotionEnvelope, _hull
from renderer.skin import one_ring

#: A vertex moved by less than this fraction of the eye distance (a fifth of a pixel at the
#: default size, as for avatars: :class:`renderer.avatar.AvatarRig`) is not moved.
MOTION_TOLERANCE = 0.002


#: Head weights are binned this finely; a point is kept at both ends of its bin (the turn's
#: blend is linear in the weight, and a segment projects to a segment).
WEIGHT_BINS = 10


def moved_between(rig: MeshRig, frames: np.ndarray) -> np.ndarray:
    """The vertices whose position differs between a frame of ``frames`` (T, V, 3) and its
    mouth at rest by more than the tolerance, in some frame."""
    fp = rig.face.feature_points
    tol = MOTION_TOLERANCE * float(np.linalg.norm(fp["3.5"] - fp["3.6"]))
    idx = rig._moving
    diff = rig.lower[idx][None] * (rig.v0[idx][None] - frames[:, idx])  # rest minus moving
    return idx[(np.abs(diff).max(axis=2) > tol).any(axis=0)]


def mesh_envelope(rig: MeshRig, frames: np.ndarray) -> MotionEnvelope:
    """The envelope of the mouth's motion over ``frames`` (T, V, 3) (see the module)."""
    moved = moved_between(rig, frames)
    face = rig.face
    if not len(moved):
        return MotionEnvelope(np.zeros((0, 3)), np.zeros(0))
    shaded = one_ring(face.triangles, moved, face.n_vertices)
    touched = np.isin(face.triangles, shaded).any(axis=1)
    corners = np.unique(face.triangles[touched])
    at = frames[:, corners].astype(np.float64)
    rest = at + rig.lower[corners][None].astype(np.float64) * (
        rig.v0[corners][None].astype(np.float64) - at
    )
    lo = np.minimum(at.min(axis=0), rest.min(axis=0))
    hi = np.maximum(at.max(axis=0), rest.max(axis=0))
    pick = np.array([[(k >> a) & 1 for a in range(3)] for k in range(8)], bool)
    boxes = np.where(pick[None], hi[:, None], lo[:, None]).reshape(-1, 3)
    w = np.repeat(np.asarray(rig.weights["head"], dtype=np.float64)[corners], 8)
    ends = [np.floor(w * WEIGHT_BINS) / WEIGHT_BINS, np.ceil(w * WEIGHT_BINS) / WEIGHT_BINS]
    return _hull(np.vstack([boxes, boxes]), np.concatenate(ends))
