"""The head's frame: tracker rotations to FAP 48-50 relative to a neutral, and gaze into the head.

Every importer that sees the head from outside (OpenFace from a camera, a BVH skeleton from its
torso) turns its rotations into matrices in one *face frame* and decomposes them here, so that
the FAPs mean the same everywhere:

* face frame: X to the face's own left, Y up, Z out of the face (ARKit's face frame; the frame
  GENEA's BVH skeletons stand in);
* FAP 48 (pitch, + down) is the angle about +X, FAP 49 (yaw, + to the face's left) about +Y and
  FAP 50 (roll, + towards the right shoulder) about +Z, composed as the renderer composes them,
  ``R = Ry(yaw) @ Rx(pitch) @ Rz(roll)`` (``renderer/deform.py``, ``HEAD_TURNS``).

A camera sees the head at an angle (a laptop camera below the face reads 15-20 degrees of
pitch in every frame). :func:`relative_to_neutral` expresses each frame's rotation relative to
the take's own neutral pose, ``R_rel = R_n^T R``: by default the median pose of the valid
frames, or the median over a calibration window in seconds.

Gaze: OpenFace's gaze is a direction in the camera's frame (its wiki, "Output Format":
``gaze_0/1`` are "eye gaze direction vector in world coordinates"). :func:`eye_in_head` turns a
direction into the head's frame, ``d_head = R^T d``, and reads the eyeball's yaw and pitch the
way the renderer composes them (``Ry(yaw) @ Rx(pitch)`` turning +Z). The importers turn the
gaze by the head *relative to the neutral*, ``d_head = R_rel^T d``: the avatar is seen from
where the camera was, with the neutral pose facing it, so a speaker who addresses the lens
from the neutral pose looks at the viewer, and eyes that stay on the lens while the head
turns turn exactly against the imported head. (The anatomical eye-in-head rotation,
``R^T d``, differs from it by the neutral's angle: a speaker 17 degrees below a laptop's
camera who looks into it has eyes turned 17 degrees up in the head, and an avatar given
those would look 17 degrees past its viewer.)

Example
-------
>>> yaw = np.radians([10.0, -10.0])
>>> R = rotations("Y", yaw[:, None])                      # the head turns left, then right
>>> np.degrees(head_angles(R)[:, 1]).round(6).tolist()   # FAP 49's angle
[10.0, -10.0]
>>> ahead = np.tile([0.0, 0.0, 1.0], (2, 1))             # the eyes look where they were
>>> np.degrees(eye_in_head(R, ahead)[:, 0]).round(6).tolist()
[-10.0, 10.0]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from app.errors import InputError


def rotations(order: str, angles: np.ndarray) -> np.ndarray:
    """(n, 3, 3) matrices ``R = R_a1(t1) @ R_a2(t2) ...`` for axes ``order`` (e.g. ``"XYZ"``,
    intrinsic, right-handed) and radians ``angles`` (n, len(order))."""
    a = np.asarray(angles, dtype=np.float64)
    return Rotation.from_euler(order.upper(), a.reshape(len(a), len(order))).as_matrix()


def head_angles(rot: np.ndarray) -> np.ndarray:
    """(n, 3) pitch, yaw, roll in radians of face-frame rotations (n, 3, 3), the inverse of
    ``Ry(yaw) @ Rx(pitch) @ Rz(roll)``."""
    yaw, pitch, roll = Rotation.from_matrix(rot).as_euler("YXZ").T
    return np.column_stack([pitch, yaw, roll])


def eye_in_head(rot: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(n, 2) eyeball yaw (+ to the face's left) and pitch (+ down), radians, of gaze
    ``directions`` (n, 3, face frame) seen from heads rotated by ``rot`` (n, 3, 3)."""
    d = np.einsum("nji,nj->ni", rot, np.asarray(directions, dtype=np.float64))
    yaw = np.arctan2(d[:, 0], d[:, 2])
    pitch = np.arctan2(-d[:, 1], np.hypot(d[:, 0], d[:, 2]))
    return np.column_stack([yaw, pitch])


@dataclass(frozen=True)
class Neutral:
    """Which pose the head is measured from: ``"median"`` of the take, ``"window"`` (the
    median over ``start_s``-``end_s``) or ``"none"`` (the tracker's own zero)."""

    method: str = "median"
    start_s: float = 0.0
    end_s: float = 0.0

    @classmethod
    def parse(cls, text: str) -> Neutral:
        """``median``, ``none`` or a window ``A-B`` / ``A:B`` in seconds.

        >>> Neutral.parse("0.5-2")
        Neutral(method='window', start_s=0.5, end_s=2.0)
        """
        t = text.strip().lower()
        if t in ("median", "none"):
            return cls(t)
        for sep in (":", "-"):
            a, found, b = t.partition(sep)
            if found and a:
                try:
                    start, end = float(a), float(b)
                except ValueError:
                    break
                if np.isfinite(start) and np.isfinite(end) and 0 <= start < end:
                    return cls("window", start, end)
                break
        raise InputError(
            f"expected median, none or a window START-END in seconds, got {text[:40]!r}",
            field="--neutral",
        )

    def describe(self) -> str:
        if self.method == "window":
            return f"the median pose over {self.start_s:g}-{self.end_s:g} s"
        return "the take's median pose" if self.method == "median" else "the tracker's zero"


def relative_to_neutral(
    rot: np.ndarray, times: np.ndarray, valid: np.ndarray, neutral: Neutral, path: str | None
) -> tuple[np.ndarray, np.ndarray]:
    """``R_n^T R`` for every frame, and the neutral's own pitch, yaw, roll (radians).

    The neutral rotation is built from the median of each angle over the valid frames (of the
    window), which a few frames of a lost track cannot move.
    """
    if neutral.method == "none":
        return rot, np.zeros(3)
    pick = np.asarray(valid, bool) & np.all(np.isfinite(rot.reshape(len(rot), 9)), axis=1)
    if neutral.method == "window":
        t = np.asarray(times, dtype=np.float64)
        pick &= (t >= neutral.start_s) & (t <= neutral.end_s)
        if not pick.any():
            raise InputError(
                f"no usable frame in the calibration window {neutral.start_s:g}-"
                f"{neutral.end_s:g} s",
                path=path,
                field="--neutral",
            )
    if not pick.any():
        return rot, np.zeros(3)
    angles = np.median(head_angles(rot[pick]), axis=0)
    pitch, yaw, roll = angles
    base = rotations("YXZ", np.array([[yaw, pitch, roll]]))[0]
    return np.einsum("ji,njk->nik", base, rot), angles
