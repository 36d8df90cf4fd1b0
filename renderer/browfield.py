"""The eyebrow raise field: how FAPs 31-36 move the skin around each brow.

The MPEG-4 player moves skin by radial raised-cosine zones around each feature point (project
reference ``mpeg4-fap``; :mod:`renderer.deform`). Around a brow those zones leave a fold:
off the line of points their sum falls below one, so raised brows sank into an oblique dent
in the forehead. :func:`brow_field` replaces them by a field separable in the face's width
and height.

Example
-------
>>> import numpy as np
>>> pts = np.array([[5.0, 0.0, 10.0], [15.0, 1.0, 9.0], [25.0, 0.0, 7.0]])
>>> w = brow_field(pts.copy(), pts, np.array([15.0, -10.0, 9.0]), ens0=20.0)
>>> np.round(w, 6).tolist()  # each point moves by its own FAP alone
[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
"""

from __future__ import annotations

import numpy as np

from renderer.sdf import smoothstep

#: How far a brow may lower, as a share of the room it squeezes (brow to upper lid margin,
#: divided by the steepest slope of the field there): beyond it that skin would fold over.
BROW_LOWER_ROOM = 0.6
#: The brow field reaches its full weight this far (in ENS0) below the brow line, so the
#: painted brow moves as a whole.
BROW_RAMP_END = 0.12


def brow_field(v: np.ndarray, points: np.ndarray, lid: np.ndarray, ens0: float) -> np.ndarray:
    """Weights (3, n) of one eyebrow's three FAPs (inner, middle, outer point) on vertices ``v``.

    A smooth field, separable in the face's width and height, so a brow raise moves the brow
    as a whole and stretches forehead and upper lid evenly, with no fold at any value:

    * across: a partition of unity between the points (``cos^2`` / ``sin^2`` ramps), so each
      point moves by its own FAP alone and equal values move the brow uniformly; medially the
      inner weight falls to 1/2 at the midline (both brows raised together lift the glabella
      evenly), laterally the outer one fades out over 0.5 ENS0 towards the temple;
    * up: 0 at the upper lid margin (``lid``; the eye opening keeps its size), rising
      smoothly to 1 just below the brow line, 1 across the brow, then fading out over the
      forehead to 1.1 ENS0 above it;
    * depth: only the front of the head (within 0.6 ENS0 behind the outer point).

    The raised-cosine zones of the MPEG-4 player (used for the lips) are radial, so off the
    line of points their sum falls below one: raised brows then sank into an oblique dent.
    """
    x = np.abs(v[:, 0])
    px = np.abs(points[:, 0])
    y_brow = np.interp(x, px, points[:, 1])  # the brow line (held beyond its ends)
    w = np.zeros((3, len(v)))
    for j in range(3):
        if j > 0:  # rising from the previous point
            t = np.clip((x - px[j - 1]) / (px[j] - px[j - 1]), 0, 1)
            rise = np.sin(0.5 * np.pi * t) ** 2
        else:  # medially: 1/2 at the midline
            rise = 0.5 + 0.5 * np.sin(0.5 * np.pi * np.clip(x / px[0], 0, 1)) ** 2
        if j < 2:
            t = np.clip((x - px[j]) / (px[j + 1] - px[j]), 0, 1)
            fall = np.cos(0.5 * np.pi * t) ** 2
        else:  # laterally, over 0.5 ENS0
            fall = np.cos(0.5 * np.pi * np.clip((x - px[j]) / (0.5 * ens0), 0, 1)) ** 2
        w[j] = np.where(x < px[j], rise, fall)
    # across the midline the inner weight goes on falling, to 0 at the other inner point
    other = v[:, 0] * points[0, 0] < 0
    w[0] = np.where(other, np.where(x < px[0], 1.0 - w[0], 0.0), w[0])
    w[1:] *= ~other
    up = smoothstep(lid[1], y_brow - BROW_RAMP_END * ens0, v[:, 1])
    up = up * (1.0 - smoothstep(y_brow + 0.1 * ens0, y_brow + 1.1 * ens0, v[:, 1]))
    depth = smoothstep(points[2, 2] - 0.6 * ens0, points[2, 2] - 0.3 * ens0, v[:, 2])
    return w * (up * depth)[None]
