import numpy as np
import pytest
from statsmodels.stats.multitest import multipletests

from app.analysis.ttest import holm, paired_t, paired_t_many

DRUG1 = [0.7, -1.6, -0.2, -1.2, -0.1, 3.4, 3.7, 0.8, 0.0, 2.0]
DRUG2 = [1.9, 0.8, 1.1, 0.1, -0.1, 4.4, 5.5, 1.6, 4.6, 3.4]


def test_student_sleep_data_as_spss_reports_it():
    r = paired_t(DRUG1, DRUG2)
    assert r["mean"] == pytest.approx(-1.58)
    assert r["sd"] == pytest.approx(1.229995, abs=1e-6)
    assert r["sem"] == pytest.approx(0.388959, abs=1e-6)
    assert r["ci_low"] == pytest.approx(-2.459886, abs=1e-6)
    assert r["ci_high"] == pytest.approx(-0.700114, abs=1e-6)
    assert r["t"] == pytest.approx(-4.062128, abs=1e-6)
    assert r["df"] == 9 and r["n"] == 10
    assert r["p"] == pytest.approx(0.0028329, abs=1e-7)


def test_missing_pairs_are_dropped_pairwise():
    a = np.array(DRUG1 + [np.nan, 5.0])
    b = np.array(DRUG2 + [1.0, np.nan])
    assert paired_t(a, b)["t"] == pytest.approx(-4.062128, abs=1e-6)


def test_no_spread_gives_no_t():
    r = paired_t([1, 2, 3], [0, 1, 2])
    assert r["mean"] == 1 and r["sd"] == 0 and r["t"] is None and r["p"] is None


def test_many_matches_scipy():
    from scipy import stats

    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(30, 4)), rng.normal(size=(30, 4))
    res = paired_t_many(a, b)
    for k in range(4):
        ref = stats.ttest_rel(a[:, k], b[:, k])
        assert res["t"][k] == pytest.approx(ref.statistic)
        assert res["p"][k] == pytest.approx(ref.pvalue)


def test_holm_vector():
    assert holm([0.01, 0.04, 0.03, 0.005]) == pytest.approx([0.03, 0.06, 0.06, 0.02])


def test_holm_matches_statsmodels_and_skips_nan():
    rng = np.random.default_rng(2)
    p = rng.random(12) ** 3
    assert holm(p) == pytest.approx(multipletests(p, method="holm")[1])
    out = holm([0.01, np.nan, 0.04])
    assert np.isnan(out[1]) and out[[0, 2]] == pytest.approx([0.02, 0.04])
