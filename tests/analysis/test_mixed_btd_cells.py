"""The vote cells of :mod:`app.analysis.mixed_btd_cells`."""

import numpy as np
import pytest
from scipy import sparse

from app.analysis.mixed_btd_cells import Cells, incidences, sparse_product_into


def test_incidences_sum_cells_into_participants_clips_and_blocks_by_hand():
    # two cells: participant 1, clip 0, 0 left of 2; participant 0, clip 1, 1 left of 0
    cells = Cells(np.array([1, 0]), np.array([0, 1]), np.array([0, 1]), np.array([2, 0]))
    to_p, to_k, to_block = incidences(cells, (2, 2, 3), width=8, offset=2, index=np.int32)
    x = np.array([10.0, 100.0])
    by_p = (to_p @ x).reshape(2, 3)
    np.testing.assert_array_equal(by_p, [[-100, 100, 0], [10, 0, -10]])
    np.testing.assert_array_equal((to_k @ x).reshape(2, 3), [[10, 0, -10], [-100, 100, 0]])
    block = (to_block @ x).reshape(2, 3, 8)  # (P, n, width): clip k's n x n at 2 + 3 k
    expected = np.zeros((2, 3, 8))
    expected[1, [0, 2], [2, 4]] = 10.0
    expected[1, [0, 2], [4, 2]] = -10.0
    expected[0, [1, 0], [6, 5]] = 100.0
    expected[0, [1, 0], [5, 6]] = -100.0
    np.testing.assert_array_equal(block, expected)


@pytest.mark.parametrize("columns", [None, 1, 3])
def test_a_sparse_product_written_into_an_array_is_scipys(columns):
    rng = np.random.default_rng(7)
    matrix = sparse.random_array((40, 25), density=0.2, format="csc", rng=rng)
    x = rng.normal(size=25 if columns is None else (25, columns))
    out = np.full((40,) if columns is None else (40, columns), np.nan)
    np.testing.assert_allclose(sparse_product_into(matrix, x, out), matrix @ x, rtol=1e-14)
    np.testing.assert_allclose(out, matrix @ x, rtol=1e-14)
    strided = np.asfortranarray(x) if columns else x[::1]
    np.testing.assert_allclose(sparse_product_into(matrix, strided, out), matrix @ x, rtol=1e-14)
