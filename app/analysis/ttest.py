"""Paired t-tests on per-participant scores, reported as SPSS reports them, with Holm's step-down.

The thesis (sec. 5.2-5.3) compares conditions by the ballots each one collects; per participant,
a condition's score is the number of that participant's ballots for it, and two conditions are
compared by a paired (dependent-samples) t-test across participants. SPSS's "Paired Samples
Test" table gives, for the differences d = a - b: mean, standard deviation (n - 1), standard
error of the mean, the 95 % confidence interval of the difference, t = mean / SEM, df = n - 1 and
the two-tailed p. Holm (1979) controls the family-wise error over the C(k, 2) pairs:
p_(i) adjusted = max over j <= i of min(1, (m - j + 1) p_(j)) for ascending p.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats


def holm(p_values: ArrayLike) -> np.ndarray:
    """Holm-adjusted p-values in the input order; NaN entries stay NaN and are not counted.

    >>> holm([0.01, 0.04, 0.03, 0.005]).round(4).tolist()
    [0.03, 0.06, 0.06, 0.02]
    """
    p = np.asarray(p_values, dtype=float)
    out = np.full(p.shape, np.nan)
    ok = np.flatnonzero(~np.isnan(p))
    if ok.size == 0:
        return out
    order = ok[np.argsort(p[ok], kind="stable")]
    m = order.size
    scaled = np.minimum(1.0, (m - np.arange(m)) * p[order])
    out[order] = np.maximum.accumulate(scaled)
    return out


def paired_t(a: ArrayLike, b: ArrayLike, *, confidence: float = 0.95) -> dict[str, float | None]:
    """SPSS-style paired t-test of a - b over the pairs where both are present.

    >>> r = paired_t([0.7, -1.6, -0.2, -1.2, -0.1, 3.4, 3.7, 0.8, 0.0, 2.0],
    ...              [1.9, 0.8, 1.1, 0.1, -0.1, 4.4, 5.5, 1.6, 4.6, 3.4])
    >>> round(r["t"], 6), r["df"], round(r["p"], 7)
    (-4.062128, 9, 0.0028329)
    """
    res = paired_t_many(
        np.asarray(a, dtype=float)[:, None],
        np.asarray(b, dtype=float)[:, None],
        confidence=confidence,
    )
    return {
        k: (None if np.isnan(v[0]) else (int(v[0]) if k in ("n", "df") else float(v[0])))
        for k, v in res.items()
    }


def paired_t_many(
    a: np.ndarray, b: np.ndarray, *, confidence: float = 0.95
) -> dict[str, np.ndarray]:
    """Column-wise :func:`paired_t`: ``a`` and ``b`` shape (participants, tests), NaN = absent.

    Where the differences have no spread (SD 0) or fewer than two pairs, t, p and the interval
    are NaN - as SPSS, which declines to compute them.
    """
    d = a - b
    present = ~np.isnan(d)
    n = present.sum(axis=0).astype(float)
    dz = np.where(present, d, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = dz.sum(axis=0) / n
        dev = np.where(present, d - mean, 0.0)
        sd = np.sqrt((dev**2).sum(axis=0) / (n - 1))
        sem = sd / np.sqrt(n)
        usable = (n >= 2) & (sd > 1e-12 * np.maximum(1.0, np.abs(mean)))
        df = np.where(n >= 2, n - 1, np.nan)
        t = np.where(usable, mean / np.where(usable, sem, 1.0), np.nan)
        p = np.where(usable, 2.0 * stats.t.sf(np.abs(t), np.where(usable, df, 1.0)), np.nan)
        q = np.where(usable, stats.t.ppf(0.5 + confidence / 2.0, np.where(usable, df, 1.0)), np.nan)
    mean = np.where(n >= 1, mean, np.nan)
    sd = np.where(n >= 2, sd, np.nan)
    sem = np.where(n >= 2, sem, np.nan)
    return {
        "n": n,
        "mean": mean,
        "sd": sd,
        "sem": sem,
        "ci_low": mean - q * sem,
        "ci_high": mean + q * sem,
        "t": t,
        "df": df,
        "p": p,
    }
