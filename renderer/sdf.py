"""Signed-distance primitives for the built-in head (vectorised over (n, 3) point arrays).

Parke's parameterised face (thesis sec. 2.1.2) places a polygon mesh by a handful of shape
parameters; the built-in head does the same, but describes the neutral shape as smooth unions of
ellipsoids and capsules (the polynomial smooth minimum) so that the sampled surface is organic.
Distances are approximate (the ellipsoid bound) - good enough for root finding along rays.
"""

from __future__ import annotations

import numpy as np


def ellipsoid(
    p: np.ndarray, centre: tuple[float, float, float], radii: tuple[float, float, float]
) -> np.ndarray:
    """Approximate signed distance to an axis-aligned ellipsoid (negative inside)."""
    q = (p - np.asarray(centre)) / np.asarray(radii)
    k0 = np.linalg.norm(q, axis=-1)
    k1 = np.linalg.norm(q / np.asarray(radii), axis=-1)
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-9)


def capsule(
    p: np.ndarray,
    a: tuple[float, float, float],
    b: tuple[float, float, float],
    ra: float,
    rb: float,
) -> np.ndarray:
    """Signed distance to a capsule from ``a`` to ``b`` whose radius goes ``ra`` -> ``rb``."""
    a_ = np.asarray(a, dtype=np.float64)
    ab = np.asarray(b, dtype=np.float64) - a_
    ap = p - a_
    t = np.clip(ap @ ab / (ab @ ab), 0.0, 1.0)
    closest = a_ + t[..., None] * ab
    return np.linalg.norm(p - closest, axis=-1) - (ra + (rb - ra) * t)


def smin(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum (smooth union) with blend radius ``k``."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b + (a - b) * h - k * h * (1.0 - h)


def smax(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Smooth maximum (smooth intersection / subtraction with ``-b``)."""
    return -smin(-a, -b, k)


def smoothstep(e0: float | np.ndarray, e1: float | np.ndarray, x: np.ndarray) -> np.ndarray:
    """Hermite step from 0 at ``e0`` to 1 at ``e1`` (either order)."""
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def ray_surface(
    sdf, origin: np.ndarray, directions: np.ndarray, t_max: float, iterations: int = 40
) -> np.ndarray:
    """Distance along each ray from ``origin`` to the surface ``sdf = 0`` (bisection).

    The shape must be star-shaped about ``origin`` (inside at the origin, outside at
    ``t_max``), which holds for the built-in head.
    """
    lo = np.zeros(directions.shape[0])
    hi = np.full(directions.shape[0], float(t_max))
    for _ in range(iterations):
        mid = (lo + hi) / 2.0
        inside = sdf(origin + mid[:, None] * directions) < 0.0
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    return (lo + hi) / 2.0
