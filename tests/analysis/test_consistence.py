from itertools import combinations

import numpy as np
import pytest

from app.analysis.consistence import (
    circular_triads_from_scores,
    coefficient_of_consistence,
    consistence_p,
    consistence_table,
    count_circular_triads,
    exact_distribution,
    max_circular_triads,
)


def test_dog_food_judge(analysis_data):
    beats = np.loadtxt(analysis_data / "dogfood-one-judge.txt").astype(bool)
    assert beats.sum(axis=1).tolist() == [4, 2, 4, 1, 2, 2]
    r = coefficient_of_consistence(beats)
    assert r["d"] == 5 and r["d_max"] == 8 and r["expected_d"] == 5
    assert r["zeta"] == pytest.approx(0.375)
    assert r["p"] == pytest.approx(0.50928, abs=5e-6)
    assert r["method"] == "exact"


def test_formula_equals_direct_count_on_random_tournaments():
    rng = np.random.default_rng(3)
    for n in (3, 4, 6, 9):
        upper = rng.random((50, n, n)) < 0.5
        beats = np.triu(upper, 1)
        beats = beats | np.swapaxes(~beats, 1, 2) & np.tril(np.ones((n, n), bool), -1)
        np.testing.assert_array_equal(
            count_circular_triads(beats), circular_triads_from_scores(beats.sum(axis=2))
        )


@pytest.mark.parametrize("n", [3, 4, 5, 6])
def test_exact_distribution_counts_all_tournaments_and_has_known_mean(n):
    dist = exact_distribution(n)
    assert dist.sum() == 2 ** (n * (n - 1) // 2)
    assert len(dist) == int(max_circular_triads(n)) + 1
    mean = (np.arange(len(dist)) * dist).sum() / dist.sum()
    assert mean == pytest.approx(n * (n - 1) * (n - 2) / 24)  # E(d) = C(n,3)/4


def test_known_small_tables():
    assert exact_distribution(3).tolist() == [6, 2]
    assert exact_distribution(4).tolist() == [24, 16, 24]  # Kendall & Babington Smith table


def test_transitive_judge_is_perfectly_consistent():
    n = 8
    beats = np.triu(np.ones((n, n), bool), 1)
    r = coefficient_of_consistence(beats)
    assert r["d"] == 0 and r["zeta"] == 1.0
    assert r["method"] == "chi2"
    # chi2 approximation: P(d <= 0) must be small but positive
    assert 0 < r["p"] < 0.01


def test_chi2_approximation_is_close_to_exact_at_n7():
    exact, _ = consistence_p(np.arange(15), 7)
    n, d = 7, np.arange(15)
    expected = n * (n - 1) * (n - 2) / 24
    nu = n * (n - 1) * (n - 2) / (n - 4) ** 2
    from scipy import stats

    approx = stats.chi2.sf(8 / (n - 4) * (expected - d + 0.5) + nu, nu)
    # Kendall's approximation is meant for n > 7; at n = 7 it already tracks the lower tail
    tail = exact < 0.05
    assert tail.sum() >= 4
    assert np.max(np.abs(approx - exact)[tail]) < 0.04


def test_ties_are_averaged_over_both_resolutions():
    # A > B, B > C, A ? C: one resolution transitive (d 0), the other circular (d 1)
    beats = np.array([[0, 1, 0], [0, 0, 1], [0, 0, 0]], bool)
    r = coefficient_of_consistence(beats)
    assert r["d"] == 0.5 and r["undetermined_pairs"] == 1
    assert r["p"] == pytest.approx((6 / 8 + 1.0) / 2)
    assert "averaged" in r["method"]


def test_too_many_ties_is_incomplete():
    table = consistence_table(np.zeros((1, 6, 6), bool))  # 15 undetermined pairs
    assert np.isnan(table["p"][0]) and table["undetermined"][0] == 15


def test_every_triad_checked():
    n = 5
    beats = np.zeros((n, n), bool)
    for i, j in combinations(range(n), 2):
        beats[i, j] = (i + j) % 2 == 0
        beats[j, i] = not beats[i, j]
    direct = sum(
        1
        for i, j, k in combinations(range(n), 3)
        if (beats[i, j] and beats[j, k] and beats[k, i])
        or (beats[j, i] and beats[k, j] and beats[i, k])
    )
    assert count_circular_triads(beats) == direct
