"""Kendall & Babington Smith (1940) coefficient of agreement u and its chi-square test.

Le, Ma & Deng 2012, sec. 8.1.1 ("Agreement test of the subjective evaluation outcomes") use u
and its chi-square to check that participants voted consistently with one another before
reading the vote counts. With ``a[i, j]`` the number of judgements preferring object i to
object j and ``m = a[i, j] + a[j, i]`` judgements of every pair (testdata README):

    Sigma = sum over i != j of C(a_ij, 2)
    u     = 2 Sigma / (C(m, 2) C(n, 2)) - 1
    chi2  = 4 / (m - 2) * (Sigma - 1/2 C(n, 2) C(m, 2) (m - 3) / (m - 2))
    df    = C(n, 2) m (m - 1) / (m - 2)^2

When pairs were judged a different number of times (a participant skipped a pair, undecided
votes were excluded), every sum above is taken pair by pair with that pair's own m: u = 2 Sigma
/ sum_p C(m_p, 2) - 1, and chi2 and df are sums of the per-pair terms (each term is Kendall's
moment-matched chi-square for one pair, so the sum reduces to the formula above when all m_p
are equal). Pairs with fewer than 3 judgements carry no information for the test and are left
out (``pairs_dropped``). The continuity-corrected chi2 subtracts 1 from Sigma (R's eba >= 1.8;
with unequal m_p the smallest step, 4 / (max m_p - 2), is subtracted).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats


@dataclass(frozen=True)
class Agreement:
    """Result of :func:`coefficient_of_agreement`; ``judges`` is m (mean m_p if unequal)."""

    u: float | None
    sigma: float
    chi2: float | None
    chi2_corrected: float | None
    df: float | None
    p: float | None
    p_corrected: float | None
    judges: float
    judges_min: int | float
    judges_max: int | float
    pairs: int
    pairs_dropped: int

    def as_dict(self) -> dict[str, float | int | None]:
        return asdict(self)


def _choose2(x: np.ndarray) -> np.ndarray:
    return x * (x - 1.0) / 2.0


def coefficient_of_agreement(counts: ArrayLike) -> Agreement:
    """Coefficient of agreement u with chi2, df and p (uncorrected and continuity-corrected).

    ``counts[i, j]``: judgements preferring i over j (may hold halves when undecided votes are
    split); the diagonal is ignored. Returns ``None`` statistics when no pair has m >= 3.

    >>> r = coefficient_of_agreement([[0, 6, 6], [0, 0, 6], [0, 0, 0]])  # 6 judges agree
    >>> round(r.u, 6), r.judges
    (1.0, 6.0)
    """
    a = np.asarray(counts, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"counts must be a square matrix, got shape {a.shape}")
    iu = np.triu_indices(a.shape[0], 1)
    upper, lower = a[iu], a.T[iu]
    m = upper + lower
    use = m >= 3
    m, upper, lower = m[use], upper[use], lower[use]
    dropped = int((~use).sum())
    if m.size == 0:
        return Agreement(None, 0.0, None, None, None, None, None, 0.0, 0, 0, 0, dropped)
    sigma_p = _choose2(upper) + _choose2(lower)
    sigma = float(sigma_p.sum())
    u = 2.0 * sigma / float(_choose2(m).sum()) - 1.0
    weight = 4.0 / (m - 2.0)
    centre = 0.5 * _choose2(m) * (m - 3.0) / (m - 2.0)
    chi2 = float((weight * (sigma_p - centre)).sum())
    df = float((m * (m - 1.0) / (m - 2.0) ** 2).sum())
    chi2_c = chi2 - 4.0 / (float(m.max()) - 2.0)
    p = float(stats.chi2.sf(chi2, df))
    p_c = float(stats.chi2.sf(chi2_c, df))
    whole = bool(np.all(m == np.round(m)))
    lo, hi = (int(m.min()), int(m.max())) if whole else (float(m.min()), float(m.max()))
    return Agreement(
        float(u), sigma, chi2, chi2_c, df, p, p_c, float(m.mean()), lo, hi, int(m.size), dropped
    )


def agreement_bounds(judges: int) -> tuple[float, float]:
    """Range of u for m judges: (-1/(m-1), 1) for even m, (-1/m, 1) for odd m (KBS 1940)."""
    return (-1.0 / (judges - 1) if judges % 2 == 0 else -1.0 / judges), 1.0
