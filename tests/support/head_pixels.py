"""The built-in head drawn for the tests that measure its pixels (``tests/renderer/``): one
square image per set of FAP values, on a mid-grey background. Nothing here is part of the
application."""

from __future__ import annotations

import numpy as np

from renderer.gl import FaceCanvas

#: The side of each drawn image, in pixels.
SIZE = 368


def draw_head(rig, *faps_list, antialias="edges"):
    """``rig`` drawn once for each mapping of ``faps_list`` (FAP number -> value, every other
    FAP neutral), in one canvas of :data:`SIZE`-pixel frames on mid grey; the images as float
    arrays, in order."""
    canvas = FaceCanvas(rig, SIZE, len(faps_list), antialias=antialias, background=(0.5, 0.5, 0.5))
    try:
        frames = []
        for faps in faps_list:
            f = np.zeros(68)
            for k, v in faps.items():
                f[k - 1] = v
            frames.append(rig.deform(f))
        img = canvas.draw(frames).copy()
    finally:
        canvas.release()
    return [img[:, k * SIZE : (k + 1) * SIZE].astype(float) for k in range(len(faps_list))]
