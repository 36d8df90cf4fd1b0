"""Mouth mosaic: pixelate the projected mouth region so lip shape cannot be read.

Per frame and face, the mouth feature points (2.2-2.9, 8.1-8.8) are projected to the image; their
bounding box, grown by a margin (a fraction of its larger side), is snapped outwards to whole
blocks of ``block`` pixels, and each block is replaced by its mean colour. Lip-reading survives
surprisingly coarse pixelation (MacDonald, Andersen & Bachmann 2000, Perception 29), hence the
coarse default (see :class:`renderer.api.RenderSettings`). Both faces of a pair get the same
block size and margin.

Even coarse blocks keep each block's mean, and the dark open mouth lowers the means of the
blocks over it: the mouth's opening stays readable as a darkening of the mosaic. The renderer
therefore takes the means from a *reference* image of the same frame with the mouth at rest
(:func:`pixelate_reference`, the face posed as it is but with the jaw and lip FAPs at zero),
so the blocks follow the head and its lighting but carry nothing of the mouth's motion, and
it blocks only face pixels: the background beside the face is never averaged in or painted
over.

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


def mouth_box(
    points: np.ndarray,
    width: int,
    height: int,
    *,
    block: int,
    margin: float,
    cover: np.ndarray | None = None,
    pad: float = 0.0,
) -> tuple[int, int, int, int]:
    """Mosaic box ``(x0, y0, x1, y1)`` (pixels, end-exclusive) around projected points.

    The box is the points' bounding box grown by ``margin`` times its larger side, and, with
    ``cover``, also holds those points' bounding box grown by ``pad`` pixels (the region the
    clip's mouth moves through, :mod:`renderer.mouthregion`); it is snapped outwards to
    multiples of ``block`` (so every block is whole) and clipped to the image.

    >>> mouth_box(np.array([[10.0, 10.0], [20.0, 14.0]]), 64, 64, block=8, margin=0.0,
    ...           cover=np.array([[12.0, 30.0]]), pad=1.0)
    (8, 8, 24, 32)
    """
    lo = points.min(axis=0)
    hi = points.max(axis=0)
    grow = margin * float(np.max(hi - lo))
    lo, hi = lo - grow, hi + grow
    if cover is not None and len(cover):
        lo = np.minimum(lo, cover.min(axis=0) - pad)
        hi = np.maximum(hi, cover.max(axis=0) + pad)
    x0 = int(np.floor(lo[0] / block)) * block
    y0 = int(np.floor(lo[1] / block)) * block
    x1 = int(np.ceil(hi[0] / block)) * block
    y1 = int(np.ceil(hi[1] / block)) * block
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


def pixelate_reference(
    image: np.ndarray,
    reference: np.ndarray,
    box: tuple[int, int, int, int],
    block: int,
    background: np.ndarray,
) -> np.ndarray:
    """Fill each ``block`` cell of ``box`` in ``image`` with the mean face colour of
    ``reference`` in that cell, on face pixels only.

    ``reference`` is the ``box`` region (its shape) of an image of the same face drawn with the
    mouth at rest; ``background`` the uint8 RGB of the empty canvas. Face pixels are those not
    exactly of the background colour; a cell with no face pixel in the reference (where only
    an opened jaw reaches) takes the mean of its own face pixels. Works in place on ``image``
    and returns it.

    Example
    -------
    >>> bg = np.array([9, 9, 9], np.uint8)
    >>> img = np.full((4, 4, 3), 9, np.uint8); img[:, :2] = 200      # face on the left
    >>> ref = np.full((4, 4, 3), 9, np.uint8); ref[:, :2] = 100
    >>> out = pixelate_reference(img, ref, (0, 0, 4, 4), 4, bg)
    >>> int(out[0, 0, 0]), int(out[0, 3, 0])                           # face <- ref, bg kept
    (100, 9)
    """
    x0, y0, x1, y1 = box
    if x1 <= x0 or y1 <= y0:
        return image
    ny, nx = (y1 - y0) // block, (x1 - x0) // block
    region = image[y0:y1, x0:x1]
    mean, counts = _face_means(reference, _face_mask(reference, background), block, background)
    face = _face_mask(region, background)
    if not counts.all():  # where only the opened jaw reaches: their own mean
        own, _ = _face_means(region, face, block, background)
        mean = np.where((counts == 0)[..., None], own, mean)
    # whole pixels as 3-byte items: a masked copy of bytes is three times slower
    colours = np.ascontiguousarray(mean, dtype=np.uint8).view("V3")[..., 0]
    np.copyto(
        region.view("V3")[..., 0].reshape(ny, block, nx, block),
        colours[:, None, :, None],
        where=face.reshape(ny, block, nx, block),
    )
    return image


def pixelate_face(
    image: np.ndarray,
    box: tuple[int, int, int, int],
    block: int,
    background: np.ndarray,
    cells: np.ndarray | None = None,
) -> np.ndarray:
    """Fill each ``block`` cell of ``box`` in ``image`` with the mean colour of its face
    pixels, on those pixels only (background pixels are neither averaged in nor painted).

    ``cells`` (rows, columns of cells) picks the cells to fill (default: all). The frame the
    renderer pixelates is the face with its mouth at rest (:mod:`renderer.pipeline`), so this
    is :func:`pixelate_reference` with the image as its own reference. Works in place and
    returns ``image``.

    >>> bg = np.array([9, 9, 9], np.uint8)
    >>> img = np.full((4, 8, 3), 9, np.uint8); img[:, :2] = [[[100]], [[200]], [[100]], [[200]]]
    >>> img[:, 4:6] = 50
    >>> out = pixelate_face(img, (0, 0, 8, 4), 4, bg, cells=np.array([[True, False]]))
    >>> int(out[0, 0, 0]), int(out[1, 1, 0]), int(out[0, 3, 0]), int(out[0, 4, 0])
    (150, 150, 9, 50)
    """
    x0, y0, x1, y1 = box
    if x1 <= x0 or y1 <= y0:
        return image
    ny, nx = (y1 - y0) // block, (x1 - x0) // block
    region = image[y0:y1, x0:x1]
    face = _face_mask(region, background)
    mean, _ = _face_means(region, face, block, background)
    where = face.reshape(ny, block, nx, block)
    if cells is not None:
        where = where & cells[:, None, :, None]
    # whole pixels as 3-byte items, as in pixelate_reference
    colours = np.ascontiguousarray(mean, dtype=np.uint8).view("V3")[..., 0]
    np.copyto(
        region.view("V3")[..., 0].reshape(ny, block, nx, block),
        colours[:, None, :, None],
        where=where,
    )
    return image


def cells_meeting(
    polygon: np.ndarray, box: tuple[int, int, int, int], block: int, pad: float = 0.0
) -> np.ndarray:
    """Which ``block`` cells of ``box`` (rows, columns) meet the convex ``polygon`` (k, 2)
    (pixels, any order of its corners) grown by ``pad`` pixels.

    Separating axes (Gottschalk, Lin & Manocha, "OBBTree", SIGGRAPH 1996): a cell and a
    convex polygon are apart exactly when their projections part on one of the cell's two
    axes or on one of the polygon's edge normals.

    >>> square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    >>> cells_meeting(square, (0, 0, 24, 8), 8).astype(int).tolist()
    [[1, 1, 0]]
    """
    from scipy.spatial import ConvexHull, QhullError

    x0, y0, x1, y1 = box
    ny, nx = (y1 - y0) // block, (x1 - x0) // block
    if ny == 0 or nx == 0 or len(polygon) == 0:
        return np.zeros((ny, nx), bool)
    try:
        corners = polygon[ConvexHull(polygon).vertices]
    except QhullError:  # flat or a point: its bounding box's corners
        lo, hi = polygon.min(axis=0), polygon.max(axis=0)
        corners = np.array([lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]])
    ys, xs = np.mgrid[0:ny, 0:nx]
    lo = np.stack([x0 + xs * block - pad, y0 + ys * block - pad], -1).reshape(-1, 2)
    hi = lo + block + 2 * pad
    meets = (
        (lo[:, 0] <= corners[:, 0].max())
        & (hi[:, 0] >= corners[:, 0].min())
        & (lo[:, 1] <= corners[:, 1].max())
        & (hi[:, 1] >= corners[:, 1].min())
    )
    edges = np.roll(corners, -1, axis=0) - corners
    normals = np.column_stack([-edges[:, 1], edges[:, 0]])
    on_poly = corners @ normals.T  # (k, edges)
    p_lo, p_hi = on_poly.min(axis=0), on_poly.max(axis=0)
    cell = np.stack(
        [lo, np.column_stack([hi[:, 0], lo[:, 1]]), hi, np.column_stack([lo[:, 0], hi[:, 1]])], 1
    )
    on_cell = cell @ normals.T  # (cells, 4, edges)
    apart = (on_cell.max(axis=1) < p_lo) | (on_cell.min(axis=1) > p_hi)
    return (meets & ~apart.any(axis=1)).reshape(ny, nx)


def _face_mask(pixels: np.ndarray, background: np.ndarray) -> np.ndarray:
    """(h, w) True where ``pixels`` (h, w, 3) are not exactly ``background``."""
    return (
        (pixels[..., 0] != background[0])
        | (pixels[..., 1] != background[1])
        | (pixels[..., 2] != background[2])
    )


def _face_means(
    pixels: np.ndarray, face: np.ndarray, block: int, background: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per ``block`` cell of ``pixels`` (h, w, 3) uint8: the rounded mean colour of its
    ``face`` pixels (0 where there are none) and their count.

    Sums every pixel in two contiguous passes (rows of a cell, then its columns) and takes the
    background's share back out, rather than masking a widened copy: this runs for every
    face and frame.
    """
    h, w, _ = pixels.shape
    ny, nx = h // block, w // block
    counts = face.reshape(ny, block, nx, block).sum(axis=(1, 3))
    total = pixels.reshape(ny, block, w * 3).sum(axis=1, dtype=np.int64)
    total = total.reshape(ny, nx, block, 3).sum(axis=2)
    total -= (block * block - counts)[..., None] * background.astype(np.int64)
    mean = (total + counts[..., None] // 2) // np.maximum(counts, 1)[..., None]
    return mean, counts
