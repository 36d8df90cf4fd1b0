"""The vote cells of the mixed Bradley-Terry-Davidson model (:mod:`app.analysis.mixed_btd_model`)
as sparse matrices, and products with them written into given arrays.

A cell is one (participant, clip, left, right) combination that holds votes. A vote's
log-likelihood depends on its worths through a_i - a_j alone, so its derivative in a_j is
minus that in a_i, and its n x n Hessian block is its second derivative in that difference
times (e_i - e_j)(e_i - e_j)'. The sums of the cells into participants, clips and
(participant, clip) blocks are therefore products with fixed signed incidence matrices, made
once, a column per cell: one sparse product against several quantities at once is 3-10x
faster than a bincount per quantity and side, and the columns need no sorting to build.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from scipy import sparse


class Cells(NamedTuple):
    """Each cell's participant, clip, left and right condition (index arrays of one length)."""

    p: np.ndarray
    k: np.ndarray
    i: np.ndarray
    j: np.ndarray


def incidences(
    cells: Cells, shape: tuple[int, int, int], width: int, offset: int, index: type
) -> tuple[sparse.csc_array, sparse.csc_array, sparse.csc_array]:
    """The signed incidence matrices of ``cells`` for ``shape`` (P, K, n) and ``index`` (the
    integer type of the indices): into participants' worths (P n rows, +1 at i, -1 at j),
    into clips' worths (K n rows, the same) and into the n x n blocks of each (participant,
    clip) laid out as the participant-dense block B (P, n, ``width``) of the model holds them
    after its ``offset`` fixed-effect columns (+1 at (i, i) and (j, j), -1 at (i, j) and (j,
    i)), so the product lands in B itself."""
    participants, _, n = shape
    count = len(cells.p)
    pair_signs = np.tile(np.array([1.0, -1.0]), count)  # i then j, shared by two matrices
    pair_starts: np.ndarray = np.arange(0, 2 * count + 1, 2, dtype=index)
    to_p = sparse.csc_array(
        (pair_signs, _interleaved(cells.p * n, [cells.i, cells.j], index), pair_starts),
        shape=(participants * n, count),
    )
    to_k = sparse.csc_array(
        (pair_signs, _interleaved(cells.k * n, [cells.i, cells.j], index), pair_starts),
        shape=(shape[1] * n, count),
    )
    corner = cells.p * (n * width)  # the block's (0, 0)
    corner += cells.k * n + offset
    row_i, row_j = cells.i * width, cells.j * width
    rows = [row_i + cells.i, row_j + cells.j, row_i + cells.j, row_j + cells.i]
    to_block = sparse.csc_array(
        (
            np.tile(np.array([1.0, 1.0, -1.0, -1.0]), count),
            _interleaved(corner, rows, index),
            np.arange(0, 4 * count + 1, 4, dtype=index),
        ),
        shape=(participants * n * width, count),
    )
    return to_p, to_k, to_block


def _interleaved(base: np.ndarray, rows: list[np.ndarray], index: type) -> np.ndarray:
    """``base + rows[q]`` for each q, interleaved: the row indices of a column per cell."""
    out: np.ndarray = np.empty(base.size * len(rows), dtype=index)
    for q, row in enumerate(rows):
        np.add(base, row, out=out[q :: len(rows)])
    return out


def sparse_product_into(matrix: sparse.csc_array, x: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``matrix @ x`` (x a vector or a C-contiguous matrix of float64) written into ``out``.

    scipy's own product makes its result anew each time: for the model's 15 MB block array
    that was a fresh allocation to fault in at every update, which cost more than the
    product. Its compiled kernels take an output array; where they are missing (a later
    scipy) the product is copied in.
    """
    kernels = _sparse_kernels()
    rows, columns = matrix.shape
    if kernels is None or x.dtype != np.float64 or not x.flags.c_contiguous:
        out[...] = matrix @ x
        return out
    out.fill(0.0)
    if x.ndim == 1:
        kernels.csc_matvec(rows, columns, matrix.indptr, matrix.indices, matrix.data, x, out)
    else:
        flat = out.reshape(-1)  # a view: out is the model's own contiguous array
        kernels.csc_matvecs(
            rows, columns, x.shape[1], matrix.indptr, matrix.indices, matrix.data, x.ravel(), flat
        )
    return out


def _sparse_kernels() -> Any:
    try:
        from scipy.sparse import _sparsetools
    except ImportError:  # pragma: no cover - scipy moved its kernels
        return None
    return _sparsetools if hasattr(_sparsetools, "csc_matvecs") else None
