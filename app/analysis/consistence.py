"""Kendall & Babington Smith (1940) coefficient of consistence zeta for one judge.

A judge who prefers A to B and B to C but C to A has made a circular triad. With s_i the wins
of object i in a complete tournament over n objects (testdata README):

    d      = n (n - 1)(2n - 1) / 12 - 1/2 sum s_i^2        (circular triads)
    zeta   = 1 - 24 d / (n^3 - n)   (n odd),   1 - 24 d / (n^3 - 4n)   (n even)
    E(d)   = C(n, 3) / 4 under random choice

The test asks whether the judge made fewer circular triads than chance: P(d <= d_obs). It is
exact for n <= 7, by enumerating all 2^C(n,2) tournaments once per n; for larger n it uses the
chi-square approximation chi2 = 8 / (n - 4) (E(d) - d + 1/2) + nu, nu = n(n-1)(n-2)/(n-4)^2
(upper tail).
"""

from __future__ import annotations

from functools import cache
from itertools import combinations
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

EXACT_MAX_N = 7
MAX_TIES = 10  # undetermined pairs resolved by enumeration (2^10 tournaments at most)


def circular_triads_from_scores(scores: ArrayLike) -> np.ndarray:
    """d from the win counts s_i of complete tournaments (last axis = objects).

    >>> float(circular_triads_from_scores([4, 2, 4, 1, 2, 2]))  # dog-food judge
    5.0
    """
    s = np.asarray(scores, dtype=float)
    n = s.shape[-1]
    return n * (n - 1) * (2 * n - 1) / 12.0 - 0.5 * (s**2).sum(axis=-1)


def count_circular_triads(beats: ArrayLike) -> np.ndarray:
    """Circular triads counted directly; ``beats[..., i, j]`` true where i was preferred to j.

    Works for incomplete tournaments too (a triad with an undetermined pair is not circular);
    for complete ones it equals :func:`circular_triads_from_scores`.
    """
    b = np.asarray(beats, dtype=bool)
    n = b.shape[-1]
    if n < 3:
        return np.zeros(b.shape[:-2], dtype=np.int64)
    tri = np.array(list(combinations(range(n), 3)))
    i, j, k = tri[:, 0], tri[:, 1], tri[:, 2]
    forward = b[..., i, j] & b[..., j, k] & b[..., k, i]
    backward = b[..., j, i] & b[..., k, j] & b[..., i, k]
    return (forward | backward).sum(axis=-1)


def max_circular_triads(n: int) -> float:
    """Largest possible d: (n^3 - n)/24 for odd n, (n^3 - 4n)/24 for even n."""
    return (n**3 - n) / 24.0 if n % 2 else (n**3 - 4 * n) / 24.0


def zeta(d: ArrayLike, n: int) -> np.ndarray:
    """Coefficient of consistence 1 - d / d_max (1 = no circular triad)."""
    return 1.0 - np.asarray(d, dtype=float) / max_circular_triads(n)


@cache
def exact_distribution(n: int) -> np.ndarray:
    """Number of tournaments on n objects with d = 0, 1, 2, ...; by full enumeration.

    >>> exact_distribution(3).tolist()  # 8 tournaments: 6 transitive, 2 circular
    [6, 2]
    """
    if n > EXACT_MAX_N:
        raise ValueError(f"exact enumeration is limited to n <= {EXACT_MAX_N}")
    edges = list(combinations(range(n), 2))
    codes = np.arange(2 ** len(edges), dtype=np.int64)
    scores = np.zeros((codes.size, n), dtype=np.int8)
    for e, (i, j) in enumerate(edges):
        bit = ((codes >> e) & 1).astype(np.int8)
        scores[:, i] += bit
        scores[:, j] += 1 - bit
    d = np.rint(circular_triads_from_scores(scores)).astype(np.int64)
    return np.bincount(d, minlength=int(max_circular_triads(n)) + 1)


def consistence_p(d: ArrayLike, n: int) -> tuple[np.ndarray, str]:
    """P(d <= observed) under random choice, and the method used ("exact" or "chi2")."""
    d = np.asarray(d, dtype=float)
    if n < 3:
        return np.full(d.shape, np.nan), "none"
    if n <= EXACT_MAX_N:
        dist = exact_distribution(n)
        cdf = np.cumsum(dist) / dist.sum()
        idx = np.clip(np.floor(d + 1e-9).astype(np.int64), 0, cdf.size - 1)
        return cdf[idx], "exact"
    expected = n * (n - 1) * (n - 2) / 24.0
    nu = n * (n - 1) * (n - 2) / (n - 4.0) ** 2
    chi2 = 8.0 / (n - 4.0) * (expected - d + 0.5) + nu
    return stats.chi2.sf(chi2, nu), "chi2"


def _average_over_ties(strict: np.ndarray, n: int) -> tuple[float, float]:
    """Mean d and mean P(d <= d_obs) over every resolution of the undetermined pairs."""
    iu, ju = np.triu_indices(n, 1)
    tied = ~(strict[iu, ju] | strict[ju, iu])
    ti, tj = iu[tied], ju[tied]
    codes = np.arange(2**ti.size)
    bits = ((codes[:, None] >> np.arange(ti.size)) & 1).astype(bool)
    full = np.repeat(strict[None], codes.size, axis=0)
    full[:, ti, tj] = bits
    full[:, tj, ti] = ~bits
    d = count_circular_triads(full)
    p, _ = consistence_p(d, n)
    return float(d.mean()), float(np.mean(p))


def consistence_table(beats: ArrayLike) -> dict[str, np.ndarray | float | int | str]:
    """Vectorised :func:`coefficient_of_consistence` over judges (``beats`` shape (J, n, n)).

    A pair the judge left undetermined (tied, or never judged) is resolved both ways: d and p
    are the averages over all equally likely resolutions, up to ``MAX_TIES`` such pairs; beyond
    that the judge's d counts determined triads only and p is NaN. Returns arrays d, zeta, p,
    undetermined pairs and complete flags, plus n, d_max, expected_d and the test method.
    """
    b = np.asarray(beats, dtype=bool)
    n = b.shape[-1]
    strict = b & ~np.swapaxes(b, -1, -2)
    off = ~np.eye(n, dtype=bool)
    decided = (strict | np.swapaxes(strict, -1, -2)) & off
    undetermined = ((~decided) & off).sum(axis=(-1, -2)) // 2
    d = count_circular_triads(strict).astype(float)
    complete = undetermined == 0
    p, method = consistence_p(d, n)
    p = np.where(complete, p, np.nan)
    if n >= 3:
        tied = np.flatnonzero((undetermined > 0) & (undetermined <= MAX_TIES))
        # judges with the same preferences share their average: each pattern is resolved
        # once (10,000 judges of 4 conditions hold a few dozen patterns)
        patterns, which = np.unique(
            strict[tied].reshape(len(tied), n * n), axis=0, return_inverse=True
        )
        for u, pattern in enumerate(patterns):
            at = tied[which.ravel() == u]
            d[at], p[at] = _average_over_ties(pattern.reshape(n, n), n)
    return {
        "n": n,
        "d": d,
        "zeta": zeta(d, n) if n >= 3 else np.full(d.shape, np.nan),
        "p": p,
        "undetermined": undetermined,
        "complete": complete,
        "d_max": max_circular_triads(n),
        "expected_d": n * (n - 1) * (n - 2) / 24.0,
        "method": method,
    }


def coefficient_of_consistence(beats: ArrayLike) -> dict[str, float | int | str | None]:
    """zeta, d, d_max, E(d) and P(d <= d_obs) for one judge's preference matrix.

    ``beats[i, j]`` is true where the judge preferred i to j. Undetermined pairs are handled as
    in :func:`consistence_table` (``method`` says "ties averaged" then).

    >>> r = coefficient_of_consistence([[0, 1, 1, 0, 1, 1], [0, 0, 0, 1, 1, 0],
    ...     [0, 1, 0, 1, 1, 1], [1, 0, 0, 0, 0, 0], [0, 0, 0, 1, 0, 1], [0, 1, 0, 1, 0, 0]])
    >>> r["d"], r["zeta"], round(r["p"], 5)
    (5.0, 0.375, 0.50928)
    """
    t = consistence_table(np.asarray(beats, dtype=bool)[None])
    return consistence_row(t, 0)


def consistence_row(table: dict[str, Any], q: int) -> dict[str, float | int | str | None]:
    """Judge ``q`` of a :func:`consistence_table` as a JSON-ready dict."""
    n = int(table["n"])
    ties = int(table["undetermined"][q])
    p = float(table["p"][q])
    if n < 3:
        method = "none"
    elif ties == 0:
        method = str(table["method"])
    elif np.isnan(p):
        method = "incomplete"
    else:
        method = f"{table['method']}, {ties} tied pair{'s' if ties > 1 else ''} averaged"
    zeta_q = float(table["zeta"][q])
    return {
        "n": n,
        "d": float(table["d"][q]),
        "d_max": float(table["d_max"]),
        "expected_d": float(table["expected_d"]),
        "zeta": None if np.isnan(zeta_q) else zeta_q,
        "p": None if np.isnan(p) else p,
        "method": method,
        "undetermined_pairs": ties,
    }
