import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from app.analysis.signed_rank import signed_rank_p, signed_rank_test


def _enumerated(row: np.ndarray) -> tuple[float, float]:
    """W and the two-sided exact p by brute force: T+ (mid-ranks of the non-zero |d|) under
    every one of the 2^m sign flips, counted."""
    d = row[row != 0]
    ranks = stats.rankdata(np.abs(d))
    flips = (np.arange(2**d.size)[:, None] >> np.arange(d.size)) & 1
    totals = flips @ ranks
    observed = ranks[d > 0].sum()
    tail = min(np.mean(totals <= observed + 1e-9), np.mean(totals >= observed - 1e-9))
    return min(observed, ranks.sum() - observed), min(1.0, 2.0 * tail)


def test_a_hand_counted_case():
    """d = (1, 2, -2, 3, 0): the zero is dropped, ranks 1, 2.5, 2.5, 4; T+ = 7.5, T- = 2.5. Of
    the 16 sign flips, T+ <= 2.5 in 4 (0, 1, 2.5, 2.5): p = 2 * 4/16 = 0.5."""
    w, p = signed_rank_test(np.array([[1.0, 2.0, -2.0, 3.0, 0.0]]))
    assert w[0] == 2.5 and p[0] == pytest.approx(0.5, abs=1e-15)


def test_all_one_sign_without_ties_is_two_over_two_to_the_n():
    w, p = signed_rank_test(np.array([[0.1, 0.2, 0.3, 0.4, 0.5, 0.6], [-1, -2, -3, -4, -5, -6]]))
    assert list(w) == [0, 0] and list(p) == pytest.approx([2 / 64, 2 / 64], abs=1e-15)


def test_rows_of_zeros_have_nothing_to_test():
    w, p = signed_rank_test(np.zeros((2, 4)))
    assert list(w) == [0, 0] and np.isnan(p).all()
    w, p = signed_rank_test(np.zeros((1, 20)))
    assert w[0] == 0 and np.isnan(p[0])


@given(st.integers(1, 16), st.integers(0, 2**31))
@settings(max_examples=30, deadline=None)
def test_every_row_is_the_exact_permutation_test(n, seed):
    """Up to 13 differences against the sign flips counted (what scipy enumerates, 2^n flips a
    row, with ties or zeros); beyond, scipy's own normal approximation."""
    d = np.random.default_rng(seed).integers(-3, 4, size=(6, n)) / 4
    w, p = signed_rank_test(d)
    for row, wr, pr in zip(d, w, p, strict=True):
        if not np.any(row != 0):
            assert np.isnan(pr) and wr == 0
        elif n <= 13:
            assert (wr, pr) == pytest.approx(_enumerated(row), abs=1e-12)
        else:
            expected = stats.wilcoxon(row, zero_method="wilcox")
            assert wr == expected.statistic
            assert pr == pytest.approx(expected.pvalue, abs=1e-12)


@pytest.mark.parametrize("seed", [3, 8])
def test_it_is_scipys_test_with_ties_and_zeros(seed):
    d = np.random.default_rng(seed).integers(-3, 4, size=(3, 9)) / 4
    assert np.any(d == 0)
    w, p = signed_rank_test(d)
    for row, wr, pr in zip(d, w, p, strict=True):
        expected = stats.wilcoxon(row, zero_method="wilcox")
        assert wr == expected.statistic
        assert pr == pytest.approx(expected.pvalue, abs=1e-12)


@pytest.mark.parametrize("n", [5, 13, 20])
def test_without_ties_it_is_the_exact_distribution(n):
    d = np.random.default_rng(n).permutation(np.arange(1, n + 1)) * np.where(
        np.random.default_rng(n + 1).random(n) < 0.3, -1, 1
    )
    w, p = signed_rank_test(d[None, :].astype(float))
    expected = stats.wilcoxon(d, zero_method="wilcox", method="exact")
    assert w[0] == expected.statistic and p[0] == pytest.approx(expected.pvalue, abs=1e-12)


def test_p_alone_is_the_tests_p():
    d = np.random.default_rng(4).integers(-3, 4, size=(5, 9)) / 4
    np.testing.assert_array_equal(signed_rank_p(d), signed_rank_test(d)[1])


def test_beyond_13_each_row_gets_the_method_scipy_gives_it_alone():
    """A tie-free row beside a tied one: scipy given both at once takes the normal
    approximation for both (0.0076); alone, the first is exact (43 of 2^14 sign flips at least
    as extreme on each side: 0.0052)."""
    free = np.arange(1.0, 15.0) * np.where(np.arange(14) < 4, -1, 1)
    tied = np.round(free / 3)
    both = np.vstack([free, tied])
    alone = [stats.wilcoxon(row, zero_method="wilcox").pvalue for row in both]
    assert signed_rank_p(both) == pytest.approx(alone, abs=1e-12)
    assert alone[0] == pytest.approx(2 * 43 / 2**14, abs=1e-12)
    assert stats.wilcoxon(both, axis=1).pvalue[0] == pytest.approx(0.0076, abs=1e-4)


def test_a_vector_and_a_missing_difference_are_refused_by_name():
    with pytest.raises(ValueError, match=r"d must be \(rows, differences\)"):
        signed_rank_test(np.ones(3))
    with pytest.raises(ValueError, match="d holds NaN"):
        signed_rank_test(np.array([[1.0, np.nan, -2.0]]))


@given(
    st.integers(14, 400),
    st.sampled_from(["net preferences", "rounded", "continuous"]),
    st.integers(0, 2**31),
)
@settings(max_examples=120, deadline=None)
def test_the_normal_approximation_is_scipys_to_the_last_digit(size, kind, seed):
    """Beyond 13 differences the p is scipy's formula written out: equal, not close."""
    rng = np.random.default_rng(seed)
    values = {
        "net preferences": [-1.0, -0.5, 0.0, 0.5, 1.0],
        "rounded": list(np.round(rng.normal(size=9), 1)),
        "continuous": list(rng.normal(size=size)),
    }[kind]
    d = rng.choice(values, size=size)
    if not (d != 0).any():
        return
    _, p = signed_rank_test(d[None, :])
    assert p[0] == stats.wilcoxon(d, zero_method="wilcox").pvalue
