"""Marker segmentation in an IR frame: threshold, the 3x3 density rule, centres of gravity.

Thesis sec. 3.1.3, step by step:

1. the grey image is thresholded to a binary map (1: maybe a marker);
2. areas of 3x3 pixels with a density (share of ones) of at least 0.36 are candidates;
3. a candidate area grows, 3x3 to 4x4 and so on, while its density stays at or above 0.36,
   up to 10x10;
4. the marker is the centre of gravity of the grown area (eq. 1-2, missing from the copy;
   reconstructed as the weighted mean of the pixel coordinates,
   ``x_c = sum(w x) / sum(w)``, ``y_c = sum(w y) / sum(w)``).

Choices the text leaves open, made here and kept as parameters:

* the weights ``w`` of eq. 1-2: ``"grey"`` (the grey level above the threshold, which
  places a marker to a fraction of a pixel) or ``"binary"`` (the binary map, the likelier
  reading of the thesis, quantised to the pixel grid);
* where an area grows from: the candidate windows of one marker touch each other, so each
  connected group of them is one marker and grows about its densest window (a raster scan
  that grows from its first hit, as a real-time scan would, favours the marker's top-left);
* the grown box is centred on the marker's centre of gravity once more before the final
  centre is taken, so a box that grew lopsided does not cut the marker.

All windows' densities come from one summed-area table, so a frame costs a few array passes
whatever the number of markers.

Example
-------
>>> img = np.zeros((20, 20), np.uint8)
>>> img[5:8, 10:13] = 255                       # a 3x3 marker centred on pixel (11, 6)
>>> find_markers(img, threshold=128).round(2).tolist()
[[11.5, 6.5]]
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

#: Density rule of sec. 3.1.3: share of ones in a window, first and largest window sizes.
DENSITY = 0.36
FIRST_WINDOW, LARGEST_WINDOW = 3, 10


def box_sums(
    table: np.ndarray, top: np.ndarray, left: np.ndarray, k: np.ndarray | int
) -> np.ndarray:
    """Sums of ``k`` x ``k`` boxes at (``top``, ``left``) from a zero-padded summed-area table,
    boxes clipped to the image."""
    h, w = table.shape[0] - 1, table.shape[1] - 1
    t, b = np.clip(top, 0, h), np.clip(top + k, 0, h)
    lo, r = np.clip(left, 0, w), np.clip(left + k, 0, w)
    return table[b, r] - table[t, r] - table[b, lo] + table[t, lo]


def summed_area(values: np.ndarray) -> np.ndarray:
    """Summed-area table with a zero first row and column: ``S[i, j] = values[:i, :j].sum()``."""
    out = np.zeros((values.shape[0] + 1, values.shape[1] + 1), np.float64)
    out[1:, 1:] = values.astype(np.float64).cumsum(axis=0).cumsum(axis=1)
    return out


def find_markers(
    image: np.ndarray,
    threshold: float = 128.0,
    *,
    density: float = DENSITY,
    largest: int = LARGEST_WINDOW,
    weights: str = "grey",
) -> np.ndarray:
    """Centres of the markers in one grey frame, (k, 2) pixel coordinates (x right, y down,
    the centre of pixel (i, j) at (j + 0.5, i + 0.5)), top to bottom.

    ``threshold`` in the image's grey levels; ``weights`` ``"grey"`` or ``"binary"`` (see the
    module text).
    """
    grey = np.asarray(image, dtype=np.float64)
    if grey.ndim == 3:
        grey = grey.mean(axis=2)
    ones = grey >= threshold
    table = summed_area(ones)
    n_first = FIRST_WINDOW * FIRST_WINDOW
    counts = (
        table[FIRST_WINDOW:, FIRST_WINDOW:]
        - table[:-FIRST_WINDOW, FIRST_WINDOW:]
        - table[FIRST_WINDOW:, :-FIRST_WINDOW]
        + table[:-FIRST_WINDOW, :-FIRST_WINDOW]
    )
    candidates = counts >= density * n_first - 1e-9  # window top-left corners
    groups, n = ndimage.label(candidates, structure=np.ones((3, 3)))
    if n == 0:
        return np.zeros((0, 2))
    # the densest window of each group (ties: the first in raster order)
    order = np.lexsort((-np.arange(counts.size), counts.ravel()))
    best = np.zeros(n + 1, np.int64)
    best[groups.ravel()[order]] = order
    seed = best[1:]
    centre_y = seed // counts.shape[1] + FIRST_WINDOW / 2.0
    centre_x = seed % counts.shape[1] + FIRST_WINDOW / 2.0
    size = _grow(table, centre_y, centre_x, density, largest)
    mass = (grey - threshold).clip(min=0.0) if weights == "grey" else ones.astype(np.float64)
    if weights not in ("grey", "binary"):
        raise ValueError(f"weights must be 'grey' or 'binary', got {weights!r}")
    tables = [
        summed_area(mass),
        summed_area(mass * (np.arange(grey.shape[1]) + 0.5)),
        summed_area(mass * (np.arange(grey.shape[0])[:, None] + 0.5)),
    ]
    for _ in range(2):  # centre of gravity in the grown box, then in the box re-centred on it
        top = np.floor(centre_y - size / 2.0 + 0.5).astype(np.int64)
        left = np.floor(centre_x - size / 2.0 + 0.5).astype(np.int64)
        m, mx, my = (box_sums(t, top, left, size) for t in tables)
        ok = m > 0
        centre_x = np.where(ok, mx / np.where(ok, m, 1.0), centre_x)
        centre_y = np.where(ok, my / np.where(ok, m, 1.0), centre_y)
    centres = np.column_stack([centre_x, centre_y])[ok]
    return _merge(centres[np.argsort(centres[:, 1], kind="stable")], 1.0)


def _grow(
    table: np.ndarray, cy: np.ndarray, cx: np.ndarray, density: float, largest: int
) -> np.ndarray:
    """Side of each area grown about (cy, cx) while its density stays >= ``density``."""
    size = np.full(len(cy), FIRST_WINDOW, np.int64)
    growing = np.ones(len(cy), bool)
    for k in range(FIRST_WINDOW + 1, largest + 1):
        top = np.floor(cy - k / 2.0 + 0.5).astype(np.int64)
        left = np.floor(cx - k / 2.0 + 0.5).astype(np.int64)
        dense = box_sums(table, top, left, k) >= density * k * k - 1e-9
        growing &= dense
        size[growing] = k
    return size


def _merge(centres: np.ndarray, within: float) -> np.ndarray:
    """Centres closer than ``within`` pixels to an earlier one dropped (one marker found twice
    when its binary map has a hole between two dense windows)."""
    if len(centres) < 2:
        return centres
    d = np.linalg.norm(centres[:, None] - centres[None], axis=2)
    dup = np.triu(d < within, k=1).any(axis=0)
    return centres[~dup]
