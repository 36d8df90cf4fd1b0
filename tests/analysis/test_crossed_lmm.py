import doctest

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.analysis import crossed_lmm
from app.analysis.crossed_lmm import fit_crossed


def test_doctest():
    assert doctest.testmod(crossed_lmm).failed == 0


def _balanced(seed, P=25, K=6, C=3, sd=(0.6, 0.4, 0.5)):
    rng = np.random.default_rng(seed)
    p, k, c = (
        a.ravel() for a in np.meshgrid(np.arange(P), np.arange(K), np.arange(C), indexing="ij")
    )
    mu = np.array([2.0, 2.6, 3.1, 3.3])[:C]
    y = (
        mu[c]
        + rng.normal(0, sd[0], P)[p]
        + rng.normal(0, sd[1], K)[k]
        + rng.normal(0, sd[2], len(p))
    )
    return y, p, k, c


def test_balanced_design_gives_the_anova_estimates():
    # In a balanced crossed design REML equals the ANOVA (moment) estimators where they are
    # positive: sigma^2 = MSE of the additive model, s_p^2 = (MS_p - MSE) / (K C),
    # s_k^2 = (MS_k - MSE) / (P C); the condition means are the MOS, with variance
    # s_p^2 / P + s_k^2 / K + sigma^2 / (P K).
    P, K, C = 25, 6, 3
    y, p, k, c = _balanced(1, P, K, C)
    grand = y.mean()
    mp = np.bincount(p, y) / (K * C)
    mk = np.bincount(k, y) / (P * C)
    mc = np.bincount(c, y) / (P * K)
    resid = y - mp[p] - mk[k] - mc[c] + 2 * grand
    mse = resid @ resid / (len(y) - P - K - C + 2)
    msp = K * C * ((mp - grand) ** 2).sum() / (P - 1)
    msk = P * C * ((mk - grand) ** 2).sum() / (K - 1)
    sp2, sk2 = (msp - mse) / (K * C), (msk - mse) / (P * C)
    assert sp2 > 0 and sk2 > 0
    fit = fit_crossed(y, c, [p, k])
    assert fit.converged
    assert fit.beta == pytest.approx(mc, abs=1e-9)
    assert fit.residual**2 == pytest.approx(mse, rel=1e-6)
    assert fit.sd**2 == pytest.approx([sp2, sk2], rel=1e-5)
    var_mean = sp2 / P + sk2 / K + mse / (P * K)
    assert np.diag(fit.cov) == pytest.approx([var_mean] * C, rel=1e-5)


def test_factor_order_and_names_do_not_matter():
    y, p, k, c = _balanced(2)
    a = fit_crossed(y, c, [p, k])
    b = fit_crossed(y, c, [k, (p * 7) % 25])  # clips first, participants renamed
    assert a.beta == pytest.approx(b.beta, abs=1e-10)
    assert a.sd == pytest.approx(b.sd[::-1], rel=1e-6)


def test_one_grouping_factor_matches_the_one_way_anova():
    # participants only, each rating every condition r times: s_p^2 = (MS_p - MSE) / (C r)
    rng = np.random.default_rng(3)
    P, C, r = 30, 2, 4
    p = np.repeat(np.arange(P), C * r)
    c = np.tile(np.repeat(np.arange(C), r), P)
    y = np.array([1.0, 1.8])[c] + rng.normal(0, 0.7, P)[p] + rng.normal(0, 0.5, len(p))
    mp = np.bincount(p, y) / (C * r)
    mc = np.bincount(c, y) / (P * r)
    resid = y - mp[p] - mc[c] + y.mean()
    mse = resid @ resid / (len(y) - P - C + 1)
    msp = C * r * ((mp - y.mean()) ** 2).sum() / (P - 1)
    fit = fit_crossed(y, c, [p])
    assert fit.beta == pytest.approx(mc, abs=1e-9)
    assert fit.sd[0] ** 2 == pytest.approx((msp - mse) / (C * r), rel=1e-5)


def test_a_variance_below_what_the_residuals_explain_is_zero():
    # clip means vary less than the residual noise alone makes them: MS_k < MSE, the REML
    # estimate is on the boundary (lme4 reports a singular fit with sd 0)
    rng = np.random.default_rng(4)
    P, K, C = 40, 5, 2
    p, k, c = (
        a.ravel() for a in np.meshgrid(np.arange(P), np.arange(K), np.arange(C), indexing="ij")
    )
    y = np.array([3.0, 3.5])[c] + rng.normal(0, 0.8, P)[p] + rng.normal(0, 0.5, len(p))
    mk = np.bincount(k, y) / (P * C)
    y = y - mk[k] + mk.mean()  # clip means made equal exactly
    fit = fit_crossed(y, c, [p, k])
    assert fit.sd[1] == 0.0
    assert fit.sd[0] > 0.5


def test_no_residual_variance_is_an_error():
    p = np.repeat(np.arange(4), 2)
    c = np.tile(np.arange(2), 4)
    with pytest.raises(ValueError, match="residual"):
        fit_crossed(np.array([1.0, 2.0] * 4), c, [p])


@settings(max_examples=60, deadline=None)
@given(
    st.integers(2, 12),
    st.integers(1, 5),
    st.integers(1, 3),
    st.floats(0.0, 0.95),
    st.integers(0, 2**31 - 1),
)
def test_any_design_fits_or_says_why(P, K, C, drop, seed):
    rng = np.random.default_rng(seed)
    p, k, c = (
        a.ravel() for a in np.meshgrid(np.arange(P), np.arange(K), np.arange(C), indexing="ij")
    )
    keep = rng.random(len(p)) >= drop
    p, k, c = p[keep], k[keep], c[keep]
    if len(p) == 0:
        return
    y = np.round(rng.normal(3, 1, len(p)) * 2) / 2  # coarse like a 5-point scale
    codes = [np.unique(g, return_inverse=True)[1] for g in (p, k, c)]
    try:
        fit = fit_crossed(y, codes[2], [codes[0], codes[1]])
    except ValueError as err:
        assert str(err)
        return
    assert np.all(np.isfinite(fit.beta)) and np.all(fit.sd >= 0) and fit.residual > 0
    assert np.all(np.diag(fit.cov) > 0)
