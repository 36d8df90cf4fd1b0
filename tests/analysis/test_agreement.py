import numpy as np
import pytest

from app.analysis.agreement import agreement_bounds, coefficient_of_agreement

# testdata README: file, m, n, Sigma, u, chi2 uncorrected, chi2 corrected, df, p corrected
VECTORS = [
    ("kendall1940-boys.txt", 21, 13, 9718, 0.186569, 412.4321, 412.2216, 90.7479, 1.721e-42),
    ("kendall1940-girls.txt", 25, 11, 8928, 0.082182, 180.2949, 180.1210, 62.3819, 2.307e-13),
    ("rumelhart1971-celebrities.txt", 234, 9, 548196, 0.117176, 1027.812, 1027.794, 36.4669, None),
]


@pytest.mark.parametrize(("name", "m", "n", "sigma", "u", "chi2", "chi2_c", "df", "p_c"), VECTORS)
def test_published_vectors(analysis_data, name, m, n, sigma, u, chi2, chi2_c, df, p_c):
    a = np.loadtxt(analysis_data / name)
    assert a.shape == (n, n)
    r = coefficient_of_agreement(a)
    assert r.judges == m and r.judges_min == r.judges_max == m
    assert r.sigma == sigma
    assert r.u == pytest.approx(u, abs=5e-7)
    assert r.chi2 == pytest.approx(chi2, abs=6e-4)
    assert r.chi2_corrected == pytest.approx(chi2_c, abs=6e-4)
    assert r.df == pytest.approx(df, abs=6e-5)
    if p_c is not None:
        assert r.p_corrected == pytest.approx(p_c, rel=5e-4)
        assert r.p < r.p_corrected
    # chi2 = df (1 + u (m - 2)), the equivalent form in the README
    assert r.chi2 == pytest.approx(r.df * (1 + r.u * (m - 2)))


def test_perfect_agreement_is_one():
    a = np.triu(np.full((4, 4), 7.0), 1)
    r = coefficient_of_agreement(a)
    assert r.u == pytest.approx(1.0)
    assert r.p < 1e-6


@pytest.mark.parametrize(("m", "win"), [(6, 3), (5, 3)])
def test_minimal_agreement_edge_cases(m, win):
    a = np.full((4, 4), float(win))
    a[np.tril_indices(4)] = m - win
    np.fill_diagonal(a, 0)
    r = coefficient_of_agreement(a)
    assert r.u == pytest.approx(-0.2)
    assert r.u == pytest.approx(agreement_bounds(m)[0])


def test_unequal_judges_sum_pair_by_pair():
    # two pairs judged by 10 and one pair by 6: chi2 and df add up per pair
    a = np.array([[0, 8, 5], [2, 0, 3], [5, 3, 0]], dtype=float)
    r = coefficient_of_agreement(a)
    assert (r.judges_min, r.judges_max, r.pairs) == (6, 10, 3)
    parts = [
        coefficient_of_agreement(np.array([[0, x], [y, 0]], dtype=float))
        for x, y in ((8, 2), (5, 5), (3, 3))
    ]
    assert r.chi2 == pytest.approx(sum(p.chi2 for p in parts))
    assert r.df == pytest.approx(sum(p.df for p in parts))
    sigma = sum(p.sigma for p in parts)
    assert r.u == pytest.approx(2 * sigma / (45 + 45 + 15) - 1)


def test_pairs_with_fewer_than_three_judgements_are_dropped():
    a = np.array([[0, 1, 5], [1, 0, 0], [0, 0, 0]], dtype=float)
    r = coefficient_of_agreement(a)
    assert (r.pairs, r.pairs_dropped) == (1, 2)
    empty = coefficient_of_agreement(np.zeros((3, 3)))
    assert empty.u is None and empty.p is None


def test_half_votes_are_accepted():
    a = np.array([[0, 4.5], [1.5, 0]])
    r = coefficient_of_agreement(a)
    # C(4.5, 2) + C(1.5, 2) = 7.875 + 0.375
    assert r.sigma == pytest.approx(8.25)
