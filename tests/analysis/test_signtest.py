import numpy as np
import pytest
from scipy import stats

from app.analysis.signtest import sign_test_p


def test_readme_vectors():
    assert sign_test_p(14, 4, 2) == pytest.approx(0.030884, abs=1e-6)
    assert sign_test_p(14, 4, 2, undecided_rule="split") == pytest.approx(0.041389, abs=1e-6)
    assert sign_test_p(14, 4, 2, undecided_rule="loss") == pytest.approx(0.115318, abs=1e-6)


def test_matches_scipy_binomtest():
    for w, lo in [(0, 0), (3, 3), (10, 1), (1, 12), (50, 38), (7, 8)]:
        ref = stats.binomtest(w, w + lo, 0.5).pvalue if w + lo else 1.0
        assert sign_test_p(w, lo) == pytest.approx(ref)


def test_half_votes_round_towards_the_null():
    # 3 undecided split: 15.5 vs 5.5 is tested as 15 vs 6, never as 16 vs 5
    assert sign_test_p(14, 4, 3, undecided_rule="split") == pytest.approx(
        stats.binomtest(15, 21, 0.5).pvalue
    )


def test_vectorised_and_rule_checked():
    p = sign_test_p(np.array([14, 4]), np.array([4, 14]), np.array([2, 2]))
    assert p[0] == pytest.approx(p[1])
    with pytest.raises(ValueError):
        sign_test_p(1, 1, undecided_rule="ignore")
