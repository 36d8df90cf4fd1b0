import numpy as np
import pytest

from app.analysis.scaling import (
    JOD_SIGMA,
    bootstrap_scale,
    canonical_participant_order,
    connected,
    thurstone_case_v,
)

EXAMPLE = [[0, 25, 0], [75, 0, 25], [0, 75, 0]]


def test_readme_example_both_anchorings():
    assert thurstone_case_v(EXAMPLE) == pytest.approx([-1, 0, 1], abs=1e-9)
    assert thurstone_case_v(EXAMPLE, anchor=0) == pytest.approx([0, 1, 2], abs=1e-9)
    assert JOD_SIGMA == pytest.approx(1.4826, abs=1e-4)


def test_complete_balanced_design_is_mostellers_row_mean():
    from scipy import stats

    truth = np.array([0.0, 0.4, 1.5, 2.0])
    p = stats.norm.cdf((truth[:, None] - truth[None, :]) / JOD_SIGMA)
    counts = np.round(p * 1000)
    counts = np.where(np.eye(4, dtype=bool), 0, counts)
    z = JOD_SIGMA * stats.norm.ppf(counts / (counts + counts.T + np.eye(4)))
    np.fill_diagonal(z, 0)
    assert thurstone_case_v(counts) == pytest.approx(z.mean(axis=1), abs=1e-9)
    assert thurstone_case_v(counts) == pytest.approx(truth - truth.mean(), abs=0.01)


def test_disconnected_design_has_no_scale():
    counts = np.zeros((4, 4))
    counts[0, 1], counts[1, 0], counts[2, 3], counts[3, 2] = 5, 5, 5, 5
    assert not connected(counts)
    assert np.isnan(thurstone_case_v(counts)).all()


def test_unanimous_pair_is_clipped_not_infinite():
    s = thurstone_case_v([[0, 10], [0, 0]])
    assert np.isfinite(s).all() and s[0] > s[1]


def test_bootstrap_interval_covers_and_is_seeded():
    rng = np.random.default_rng(0)
    truth = np.array([-1.0, 0.0, 0.5])
    from scipy import stats

    p = stats.norm.cdf((truth[:, None] - truth[None, :]) / JOD_SIGMA)
    wins = rng.binomial(4, p[None].repeat(60, 0))
    wins = np.triu(wins, 1) + np.swapaxes(np.triu(4 - wins, 1), 1, 2)
    s, lo, hi = bootstrap_scale(wins, replicates=400, seed=7)
    assert np.all(lo <= s) and np.all(s <= hi)
    assert np.all((lo <= truth - truth.mean()) & (truth - truth.mean() <= hi))
    again = bootstrap_scale(wins, replicates=400, seed=7)
    assert np.array_equal(lo, again[1]) and np.array_equal(hi, again[2])
    shuffled = wins[rng.permutation(60)]
    assert np.array_equal(bootstrap_scale(shuffled, replicates=400, seed=7)[1], lo)


def test_canonical_order_depends_on_data_only():
    data = np.random.default_rng(1).integers(0, 3, (10, 2, 2))
    a = data[canonical_participant_order(data)]
    perm = data[::-1]
    assert np.array_equal(a, perm[canonical_participant_order(perm)])
