"""The Wilcoxon signed-rank test with ties and zeros, exact for small samples, over many rows.

Wilcoxon (1945), zero_method "wilcox": differences equal to 0 are dropped, the others are
ranked by |d| with mid-ranks for ties, and

    T+ = sum of the ranks of the positive d        T- = sum of the ranks of the negative d

Under the null hypothesis every sign is + or - with probability 1/2, independently. The
two-sided p is 2 min(P(T+ <= t+), P(T+ >= t+)), at most 1, where the distribution is that of T+
over all 2^m sign flips of the m non-zero ranks. It is the p ``scipy.stats.wilcoxon(d,
zero_method="wilcox")`` returns: scipy enumerates the 2^m flips (``permutation_test``) for up to
13 differences with ties or zeros, and uses the tie-free exact distribution otherwise. Here the
flip distribution is built by convolution: doubled mid-ranks are whole numbers, and each
difference adds its doubled rank with probability 1/2,

    f_k(s) = (f_{k-1}(s) + f_{k-1}(s - 2 r_k)) / 2        f_0 = [1, 0, 0, ...]

which takes m steps over at most m (m + 1) + 1 sums (about m^3 operations) rather than 2^m
statistics, for every row of a matrix at once (the same recursion as the tie-free null
distribution of Wilcoxon 1945 and Mann & Whitney 1947, on half-ranks). Beyond 13 differences
the test is scipy's own, its method chosen for each row as a call on that row alone would
choose it: exact without ties or zeros up to 50 differences, else the normal approximation
with the tie correction, its formula written out to scipy's digits (scipy given a matrix
decides over all its rows at once).
"""

from __future__ import annotations

import numpy as np
from scipy import special, stats

EXACT_WITH_TIES_UP_TO = 13  # scipy's limit for its enumerated p (2^13 < its 9,999 resamples)


def signed_rank_test(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """W = min(T+, T-) and the two-sided p of each row of ``d`` (rows, differences).

    Every row has the same number of differences; a row of zeros has W = 0 and p = NaN (there
    is nothing to test). NaN is not a difference: callers drop missing values first.
    """
    d = np.asarray(d, dtype=float)
    if d.ndim != 2:
        raise ValueError(f"d must be (rows, differences), not of shape {d.shape}")
    if np.isnan(d).any():
        raise ValueError("d holds NaN: drop the missing differences first")
    nonzero = d != 0
    absd = np.where(nonzero, np.abs(d), np.inf)
    ranks = stats.rankdata(absd, axis=1)  # zeros (inf) rank last; they are masked out below
    doubled = np.where(nonzero, np.rint(2 * ranks), 0).astype(np.int64)
    t_plus = np.where(d > 0, doubled, 0).sum(axis=1)
    t_minus = np.where(d < 0, doubled, 0).sum(axis=1)
    w = np.minimum(t_plus, t_minus) / 2.0
    if d.shape[1] > EXACT_WITH_TIES_UP_TO:
        return w, _scipys_p(d, nonzero, t_plus / 2.0)
    top = int(doubled.sum(axis=1).max()) + 1
    dist = np.zeros((d.shape[0], top))
    dist[:, 0] = 1.0
    index = np.arange(top)
    for k in range(d.shape[1]):
        step = doubled[:, k : k + 1]
        shifted = np.where(
            index >= step,
            np.take_along_axis(dist, np.maximum(index - step, 0), axis=1),
            0.0,
        )
        dist = 0.5 * (dist + shifted)  # a zero d shifts by 0: the distribution is unchanged
    below = np.where(index <= t_plus[:, None], dist, 0.0).sum(axis=1)
    above = np.where(index >= t_plus[:, None], dist, 0.0).sum(axis=1)
    p = np.minimum(1.0, 2.0 * np.minimum(below, above))
    return w, np.where(nonzero.any(axis=1), p, np.nan)


def _scipys_p(d: np.ndarray, nonzero: np.ndarray, r_plus: np.ndarray) -> np.ndarray:
    """scipy's p of each row, its default method chosen per row as for that row alone;
    ``r_plus`` is each row's T+.

    The normal approximation is scipy's formula written out (``wilcoxon``'s "asymptotic"
    without continuity correction: z = (T+ - m (m + 1) / 4) / se with se^2 = (m (m + 1)
    (2 m + 1) - sum (t^3 - t) / 2) / 24 over the groups of t tied |d|, p = 2 Phi(-|z|)),
    to the same digits: scipy's own call spent 1.3 ms a row checking and re-ranking what
    is ranked here already."""
    magnitudes = np.sort(np.where(nonzero, np.abs(d), np.nan), axis=1)  # zeros (NaN) last
    same = np.diff(magnitudes, axis=1) == 0
    ties = same.any(axis=1)
    exact = ~ties & nonzero.all(axis=1) & (d.shape[1] <= 50)
    p = np.full(d.shape[0], np.nan)
    if exact.any():
        with np.errstate(invalid="ignore", divide="ignore"):
            found = stats.wilcoxon(d[exact], axis=1, zero_method="wilcox", method="exact")
        p[exact] = found.pvalue
    for row in np.flatnonzero(~exact):
        m = float(nonzero[row].sum())
        if m == 0:
            continue
        _, counts = np.unique(magnitudes[row, : int(m)], return_counts=True)
        tied = counts.astype(np.float64)
        mean = m * (m + 1.0) * 0.25
        se = np.sqrt((m * (m + 1.0) * (2.0 * m + 1.0) - np.sum(tied**3 - tied) / 2) / 24)
        with np.errstate(invalid="ignore", divide="ignore"):
            p[row] = 2 * special.ndtr(-np.abs((r_plus[row] - mean) / se))
    return np.where(nonzero.any(axis=1), p, np.nan)


def signed_rank_p(d: np.ndarray) -> np.ndarray:
    """The two-sided p of :func:`signed_rank_test` alone, one per row of ``d``."""
    return signed_rank_test(d)[1]
