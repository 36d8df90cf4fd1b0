"""Mouth mosaic: pixelate the projected mouth region so lip shape cannot be read.

Per frame and face, the mouth feature points (2.2-2.9, 8.1-8.8) are projected to the image; their
bounding box, grown by a margin (a fraction of its larger side), is snapped outwards to whole
blocks of ``block`` pixels, and each block is replaced by its mean colour. Lip-reading survives
surprisingly coarse pixelation (MacDonald, Andersen & Bachmann 2000, Perception 29), hence the
coarse default (see :class:`renderer.api.RenderSettings`). Both faces of a pair get the same
block size and margin.

Example
-------
>>> import numpy as np
>>> img = np.arange(48 * 48 * 3, dtype=np.uint8).reshape(48, 48, 3)
>>> box = mouth_box(np.array([[10.0, 10.0], [30.0, 20.0]]), 48, 48, block=8, margin=0.0)
>>> box
(8, 8, 32, 24)
>>> out = pixelate(img, box, 8)
>>> bool((out[8:16, 8:16] == out[8, 8]).all())
True
"""

from __future__ import annotations

import numpy as np


def mouth_box(points: np.ndarray, width: int, height: int, *, block: int,
              margin: float) -> tuple[int, int, int, int]:
    """Mosaic box ``(x0, y0, x1, y1)`` (pixels, end-exclusive) around projected points.

    The box is the points' bounding box grown by ``margin`` times its larger side, snapped
    outwards to multiples of ``block`` (so every block is whole) and clipped to the image.
    """
    lo = points.min(axis=0)
    hi = points.max(axis=0)
    grow = margin * float(np.max(hi - lo))
    x0 = int(np.floor((lo[0] - grow) / block)) * block
    y0 = int(np.floor((lo[1] - grow) / block)) * block
    x1 = int(np.ceil((hi[0] + grow) / block)) * block
    y1 = int(np.ceil((hi[1] + grow) / block)) * block
    x0, y0 = min(max(x0, 0), width), min(max(y0, 0), height)
    x1 = min(max(x1, x0), x0 + (width - x0) // block * block)
    y1 = min(max(y1, y0), y0 + (height - y0) // block * block)
    return x0, y0, x1, y1


def pixelate(image: np.ndarray, box: tuple[int, int, int, int], block: int) -> np.ndarray:
    """Replace each ``block`` x ``block`` cell of ``box`` in ``image`` by its mean colour.

    Works in place on ``image`` (H, W, 3) uint8 and returns it. The box must span whole blocks
    (as :func:`mouth_box` makes it).
    """
    x0, y0, x1, y1 = box
    if x1 <= x0 or y1 <= y0:
        return image
    ny, nx = (y1 - y0) // block, (x1 - x0) // block
    cells = image[y0:y1, x0:x1].reshape(ny, block, nx, block, 3)  # a view into ``image``
    total = cells.sum(axis=1, dtype=np.uint32).sum(axis=2)
    mean = (total + block * block // 2) // (block * block)
    cells[:] = mean.astype(np.uint8)[:, None, :, None, :]
    return image
