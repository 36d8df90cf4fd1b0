"""Sign tests for each pair of conditions: wins against losses, exact binomial, two-sided.

Le, Ma & Deng 2012, sec. 8.2 and Fig. 9 report, per pair of methods, how many votes went to
each side and how many were undecided. Under H0 (no preference) each decisive vote is a fair
coin, so wins ~ Binomial(wins + losses, 1/2); for p = 1/2 the exact two-sided p-value is
min(1, 2 P(X <= min(wins, losses))). Undecided votes are excluded by default; as sensitivity
analyses they can be split half to each side (half votes rounded towards n/2, which can only
raise p) or counted against the first condition ("loss").
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

UNDECIDED_RULES = ("exclude", "split", "loss")


def sign_test_p(
    wins: ArrayLike, losses: ArrayLike, undecided: ArrayLike = 0, *, undecided_rule: str = "exclude"
) -> np.ndarray:
    """Exact two-sided binomial p-values, element-wise.

    >>> float(sign_test_p(14, 4, 2).round(6)), float(sign_test_p(14, 4, 2,
    ...     undecided_rule="split").round(6)), float(sign_test_p(14, 4, 2,
    ...     undecided_rule="loss").round(6))
    (0.030884, 0.041389, 0.115318)
    """
    if undecided_rule not in UNDECIDED_RULES:
        raise ValueError(f"undecided_rule must be one of {UNDECIDED_RULES}")
    w = np.asarray(wins, dtype=float)
    lo = np.asarray(losses, dtype=float)
    u = np.asarray(undecided, dtype=float)
    if undecided_rule == "split":
        w, lo = w + u / 2.0, lo + u / 2.0
    elif undecided_rule == "loss":
        lo = lo + u
    n = w + lo
    k = np.ceil(np.minimum(w, lo))  # a half vote rounds towards n/2: p can only grow
    p = np.minimum(1.0, 2.0 * stats.binom.cdf(k, np.round(n).astype(np.int64), 0.5))
    return np.where(n > 0, p, 1.0)
