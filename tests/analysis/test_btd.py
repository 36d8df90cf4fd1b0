import json
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import optimize

from app.analysis import analyze
from app.analysis.btd import (
    JOD_PER_LOG_WORTH,
    btd_summary,
    fit_btd,
    fit_btd_many,
    leave_one_out_loglik,
    log_likelihood,
)

COLS = ["participant", "clip", "left", "right", "choice"]


def _brute_loglik(counts, pi, g, nu):
    """The issue's formulas, cell by cell, written out without the module's algebra."""
    total = 0.0
    n = len(pi)
    for i in range(n):
        for j in range(n):
            if i == j:
                continue
            tie = nu * math.sqrt(pi[i] * pi[j])
            d = g * pi[i] + pi[j] + tie
            left, right, und = counts[i, j]
            total += left * math.log(g * pi[i] / d) + right * math.log(pi[j] / d)
            if und:
                total += und * math.log(tie / d)
    return total


def _brute_fit(counts, ties=True):
    """Maximise the brute-force likelihood over (log pi_2..n, log g, log nu) by Nelder-Mead."""
    n = counts.shape[0]

    def negative(x):
        pi = np.exp(np.concatenate([[0.0], x[: n - 1]]))
        nu = math.exp(x[n]) if ties else 0.0
        return -_brute_loglik(counts, pi, math.exp(x[n - 1]), nu)

    x0 = np.zeros(n + int(ties))
    res = optimize.minimize(
        negative,
        x0,
        method="Nelder-Mead",
        options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 40000, "maxfev": 40000},
    )
    theta = np.concatenate([[0.0], res.x[: n - 1]])
    return (
        theta - theta.mean(),
        math.exp(res.x[n - 1]),
        (math.exp(res.x[n]) if ties else 0.0),
        -res.fun,
    )


def test_hand_solved_exact_fit():
    # pi = (4, 1), g = 2, nu = 1: cell A|B has weights 8, 1, 2 and cell B|A 2, 4, 2, so counts
    # proportional to them are fitted exactly: theta = +-ln 2
    c = np.zeros((2, 2, 3))
    c[0, 1], c[1, 0] = [8, 1, 2], [2, 4, 2]
    for scale in (1, 7):
        f = fit_btd(c * scale)
        assert f.theta == pytest.approx([math.log(2), -math.log(2)], abs=1e-7)
        assert f.gamma == pytest.approx(2.0, abs=1e-7) and f.nu == pytest.approx(1.0, abs=1e-7)
        assert f.loglik == pytest.approx(
            scale
            * (
                8 * math.log(8 / 11)
                + math.log(1 / 11)
                + 2 * math.log(2 / 11)
                + 2 * math.log(2 / 8)
                + 4 * math.log(4 / 8)
                + 2 * math.log(2 / 8)
            )
        )
    beta, ok = fit_btd_many(c[None])
    assert ok[0] and beta[0] == pytest.approx(
        [math.log(2), -math.log(2), math.log(2), 0.0], abs=1e-7
    )


def test_hand_solved_symmetric_sides():
    # The data do not change when the sides are swapped, so g = 1; then Davidson's two-item
    # model is saturated: pi_A / pi_B = 12 / 4 and nu sqrt(3) = ties / wins_B = 4 / 4
    c = np.zeros((2, 2, 3))
    c[0, 1], c[1, 0] = [6, 2, 2], [2, 6, 2]
    f = fit_btd(c)
    assert f.gamma == pytest.approx(1.0, abs=1e-7)
    assert f.nu == pytest.approx(1 / math.sqrt(3), abs=1e-7)
    assert f.theta == pytest.approx([math.log(3) / 2, -math.log(3) / 2], abs=1e-7)


@given(st.lists(st.integers(0, 6), min_size=18, max_size=18), st.booleans())
@settings(max_examples=25, deadline=None)
def test_fit_equals_brute_force_maximisation(cells, ties):
    c = np.zeros((3, 3, 3))
    off = ~np.eye(3, dtype=bool)
    c[off] = np.array(cells, dtype=float).reshape(6, 3) + [1, 1, 0]
    if ties:
        c[0, 1, 2] += 1
    else:
        c[..., 2] = 0
    f = fit_btd(c)
    theta, g, nu, ll = _brute_fit(c, ties)
    assert f.converged
    assert f.loglik == pytest.approx(ll, abs=1e-6)
    assert f.loglik >= ll - 1e-9
    assert f.theta == pytest.approx(theta, abs=1e-4)
    assert f.gamma == pytest.approx(g, rel=1e-4) and f.nu == pytest.approx(nu, abs=1e-4)
    assert log_likelihood(c, f.theta, f.gamma, f.nu) == pytest.approx(
        _brute_loglik(c, np.exp(f.theta), f.gamma, f.nu)
    )
    beta, ok = fit_btd_many(c[None])
    assert ok[0] and beta[0, :3] == pytest.approx(f.theta, abs=1e-6)


def test_no_finite_maximum_is_reported():
    c = np.zeros((3, 3, 3))
    c[0, 1], c[1, 0] = [3, 0, 0], [0, 3, 0]  # A beats B every time
    c[1, 2], c[2, 1] = [2, 1, 1], [1, 2, 0]
    f = fit_btd(c)
    assert not f.converged and "no finite" in f.note
    assert not fit_btd_many(c[None])[1][0]
    apart = np.zeros((4, 4, 3))
    apart[0, 1], apart[2, 3] = [2, 1, 1], [1, 2, 1]
    assert "do not link" in fit_btd(apart).note


def test_estimates_recover_a_known_model():
    rng = np.random.default_rng(11)
    theta = np.array([-0.6, 0.0, 0.2, 0.4])
    g, nu = 1.3, 0.5
    pi = np.exp(theta)
    c = np.zeros((4, 4, 3))
    for i in range(4):
        for j in range(4):
            if i != j:
                w = np.array([g * pi[i], pi[j], nu * math.sqrt(pi[i] * pi[j])])
                c[i, j] = rng.multinomial(4000, w / w.sum())
    f = fit_btd(c)
    assert f.theta == pytest.approx(theta, abs=0.05)
    assert f.gamma == pytest.approx(g, rel=0.05) and f.nu == pytest.approx(nu, rel=0.05)


@pytest.mark.slow
def test_summary_layout_identical_pairs_and_intervals():
    rows = []
    rng = np.random.default_rng(2)
    for k in range(12):
        for a, b in [("A", "B"), ("B", "A"), ("A", "C"), ("C", "A"), ("B", "C"), ("C", "B")]:
            z = {"A": 0.8, "B": 0.0, "C": -0.5}[a] - {"A": 0.8, "B": 0.0, "C": -0.5}[b]
            z += rng.normal()
            rows.append(
                (f"p{k}", "c", a, b, "undecided" if abs(z) < 0.3 else "left" if z > 0 else "right")
            )
    base = analyze(pd.DataFrame(rows, columns=COLS), bootstrap=200)["pooled"]["btd"]
    # identical-clip pairs are left out of the fit and reported on their own
    extra = rows + [(f"p{k}", "c", x, x, "left") for k in range(12) for x in "ABC"]
    r = analyze(pd.DataFrame(extra, columns=COLS), bootstrap=200)["pooled"]["btd"]
    assert r["scores"] == pytest.approx(base["scores"]) and r["n"] == base["n"] == 72
    assert r["identical_pairs"] == {
        "votes": 36,
        "left": 36,
        "right": 0,
        "undecided": 0,
        "share_left": 1.0,
        "p": pytest.approx(2 * 0.5**36),
    }
    assert {"scores", "nu", "gamma", "ci", "loglik", "n"} <= set(r)
    assert sum(r["scores"].values()) == pytest.approx(0.0, abs=1e-9)
    assert r["scores"]["A"] > r["scores"]["B"] > r["scores"]["C"]
    for c, (lo, hi) in r["ci"].items():
        assert lo < hi
        assert r["jod"][c] == pytest.approx(r["scores"][c] * JOD_PER_LOG_WORTH)
    assert r["gamma_ci"][0] < r["gamma"] < r["gamma_ci"][1]
    json.dumps(r, allow_nan=False)


def test_leave_one_out_loglik_by_separate_fits():
    rng = np.random.default_rng(4)
    t = rng.integers(0, 4, size=(5, 3, 3, 3)).astype(float)
    loo = leave_one_out_loglik(t)
    for p in range(5):
        rest = fit_btd(t.sum(axis=0) - t[p])
        assert loo[p] == pytest.approx(
            log_likelihood(t[p], rest.theta, rest.gamma, rest.nu), abs=1e-6
        )


def test_conditions_never_compared_get_null():
    t = np.zeros((2, 3, 3, 3))
    t[0, 0, 1], t[1, 1, 0] = [3, 1, 1], [2, 2, 1]
    r = btd_summary(t, ["A", "B", "C"], bootstrap=50)
    assert r["scores"]["C"] is None and "never compared: C" in r["note"]
    assert r["scores"]["A"] is not None


def test_two_conditions_one_winning_every_vote_has_no_estimate():
    counts = np.zeros((2, 2, 3))
    counts[0, 1, 0] = counts[1, 0, 1] = 12  # condition 0 chosen on either side
    fit = fit_btd(counts)
    assert not fit.converged and np.isnan(fit.theta).all() and "no finite" in fit.note
