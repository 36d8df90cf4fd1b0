"""An avatar's mouth, found from the shapes that open it, within the head.

The mosaic and the camera are placed by the mouth's feature points (2.2-2.9 and 8.1-8.8;
MPEG-4 FBA, the lips' inner and outer contours). An avatar without them in its sidecar gets
them from the motion of a mouth-opening shape, as the lips are what such a shape moves most:
:func:`opening_shape` picks the first of ARKit's ``jawOpen``, the VRM viseme ``aa`` (``a`` in
VRM 0.x), VRoid's ``Fcl_MTH_A``, Oculus' ``viseme_aa`` and the older Ready Player Me
``mouthOpen`` that moves anything below the eyes (VRoid exports carry an empty ``jawOpen``),
else the sum of every mouth shape; :func:`mouth_points` finds the lips in its motion, only
among the vertices a head's proportions allow (between half an eye distance and two and a
half below the eyes, near the midline), so a body's or a hand's motion can never be taken for
the mouth.

Example
-------
>>> import numpy as np
>>> v = np.array([[0, -60.0, 10], [0, -75, 10], [25, -68, 5], [-25, -68, 5], [0, -200, 0]])
>>> jaw = np.zeros_like(v); jaw[1] = [0, -8, 0]; jaw[4] = [0, -30, 0]  # lower lip; a hand
>>> pts = mouth_points(v, jaw, np.array([31.0, 0, 0]), np.array([-31.0, 0, 0]))
>>> pts["2.2"], pts["2.3"], pts["2.4"], pts["2.5"]
(0, 1, 2, 3)
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from app.errors import InputError
from renderer.face import MOUTH_FEATURE_POINTS
from renderer.shapenames import canonical

#: Shapes that open the mouth, by canonical name, in the order they are tried.
OPENING_SHAPES: tuple[str, ...] = ("jawopen", "aa", "a", "fclmtha", "visemeaa", "mouthopen")


def head_region(vertices: np.ndarray, eye_l: np.ndarray, eye_r: np.ndarray) -> np.ndarray:
    """Which vertices lie where a mouth can be: below the eyes by 0.3 to 2.5 eye distances,
    within 0.8 of one across (an adult's chin is about 1.9 eye distances below the eyes)."""
    es = float(np.linalg.norm(eye_l - eye_r))
    mid = (eye_l + eye_r) / 2.0
    v = np.asarray(vertices, dtype=np.float64)
    below = mid[1] - v[:, 1]
    return (below > 0.3 * es) & (below < 2.5 * es) & (np.abs(v[:, 0] - mid[0]) < 0.8 * es)


def opening_shape(
    shapes: Mapping[str, np.ndarray], region: np.ndarray
) -> tuple[str, np.ndarray] | None:
    """The first shape of :data:`OPENING_SHAPES` that moves a vertex of ``region``, else the
    sum of the mouth shapes (``mouth*``, visemes), as (name, displacement); None if none moves."""
    by_key = {canonical(n): n for n in shapes}
    for key in OPENING_SHAPES:
        name = by_key.get(key)
        if name is not None and np.abs(shapes[name][region]).max(initial=0.0) > 0:
            return name, np.asarray(shapes[name])
    mouth = [n for n in shapes if canonical(n).startswith(("mouth", "viseme", "fclmth"))]
    if mouth:
        total = sum(np.abs(np.asarray(shapes[n])) for n in mouth)
        if np.abs(total[region]).max(initial=0.0) > 0:
            return "the mouth shapes together", np.asarray(total)
    return None


def mouth_points(
    vertices: np.ndarray,
    jaw: np.ndarray,
    eye_l: np.ndarray,
    eye_r: np.ndarray,
) -> dict[str, int]:
    """Mouth feature points (2.2-2.9, 8.1-8.8) of an avatar as vertex indices, from the
    displacement ``jaw`` (n, 3) of a mouth-opening shape and its eye positions.

    The lower lip's middle (2.3, 8.2) is the highest vertex near the midline that the jaw
    moves by at least half its largest displacement (within :func:`head_region`), among the
    front-most ones (the lower teeth and tongue move too, behind it); the upper lip's (2.2,
    8.1) the nearest vertex above it, not behind it, that the jaw barely moves. The corners
    lie 0.4 eye distances (an adult's mouth width is about 0.8 of the pupil distance) to
    either side, set back a little; the points between are halfway. Each is the nearest
    vertex to where it is expected.
    """
    v = np.asarray(vertices, dtype=np.float64)
    es = float(np.linalg.norm(eye_l - eye_r))
    mid = (eye_l + eye_r) / 2.0
    region = head_region(v, eye_l, eye_r)
    disp = np.where(region, np.linalg.norm(jaw, axis=1), 0.0)
    near_mid = region & (np.abs(v[:, 0] - mid[0]) < 0.15 * es)
    moved = near_mid & (disp >= 0.5 * disp.max()) & (disp > 0)
    if not moved.any():
        raise InputError(
            "the mouth-opening shape moves no vertex below the eyes near the midline: the "
            "mouth cannot be found (give its feature points in the sidecar)",
            field="feature_points",
        )
    front = moved & (v[:, 2] > v[moved, 2].max() - 0.25 * es)
    central = front & (np.abs(v[:, 0] - mid[0]) < 0.05 * es)
    front = central if central.any() else front
    lower = int(np.flatnonzero(front)[np.argmax(v[front, 1])])
    above = (
        near_mid
        & (disp < 0.15 * disp.max())
        & (v[:, 1] >= v[lower, 1])
        & (v[:, 1] < v[lower, 1] + 0.5 * es)
        & (v[:, 2] > v[lower, 2] - 0.1 * es)
    )
    upper = (
        int(np.flatnonzero(above)[np.argmin(np.linalg.norm(v[above] - v[lower], axis=1))])
        if above.any()
        else _nearest(v, v[lower] + [0.0, 0.05 * es, 0.0])
    )
    centre = (v[upper] + v[lower]) / 2.0
    centre[0] = mid[0]
    corner = {s: _nearest(v, centre + [s * 0.4 * es, 0.0, -0.12 * es]) for s in (1, -1)}
    out = {"2.2": upper, "2.3": lower, "2.4": corner[1], "2.5": corner[-1]}
    for name, a, b in (
        ("2.6", upper, corner[1]),
        ("2.7", upper, corner[-1]),
        ("2.8", lower, corner[1]),
        ("2.9", lower, corner[-1]),
    ):
        out[name] = _nearest(v, (v[a] + v[b]) / 2.0)
    for inner, outer in zip(MOUTH_FEATURE_POINTS[:8], MOUTH_FEATURE_POINTS[8:], strict=True):
        out[outer] = out[inner]
    return out


def _nearest(v: np.ndarray, point: np.ndarray) -> int:
    return int(np.argmin(np.linalg.norm(v - point, axis=1)))
