"""Adaptive pairs: the next comparison by expected information gain (ASAP).

With many conditions a full pair design spends most votes on pairs whose answer is already
known. ASAP (Mikhailiuk, Wilmot, Perez-Ortiz, Yue & Mantiuk 2021, "Active sampling for
pairwise comparisons via approximate message passing and information gain maximization",
ICPR 2020, sec. III) keeps a Gaussian posterior over the scores and asks for the pair whose
answer is expected to move that posterior most: the expected Kullback-Leibler divergence from
the current posterior to the one updated with the answer.

Here the posterior is the Laplace approximation of the Bradley-Terry model (Bradley & Terry
1952; logistic in the score difference, the model of :mod:`app.analysis.btd` between decided
votes) with a N(0, prior_sd^2) prior on each score: the mode ``mean`` and the inverse Hessian
``cov`` of the log posterior. For the pair (i, j), d = e_i - e_j, m = d' mean, v = d' cov d:

    p   = sigma(m / sqrt(1 + pi v / 8))            predictive P(i chosen) (MacKay 1992)
    q   = sigma(m),  w = q (1 - q)                  the answer's information at the mode
    the answer y in {0, 1} updates by one Newton step of rank one (TrueSkill-like):
    cov' = cov - cov d d' cov w / (1 + w v),   mean' = mean + cov d (y - q) / (1 + w v)
    KL(y) = 1/2 [ln(1 + w v) - w v / (1 + w v) + (y - q)^2 v / (1 + w v)^2]
    EIG   = p KL(1) + (1 - p) KL(0)

(the Gaussian KL divergence with the rank-one update in closed form), so every pair's gain is
one vectorised expression. Undecided votes count half to each side in the posterior.

The choice obeys the counterbalancing rules of the fixed designs: only ordered pairs the study
can show (rendered) are candidates; among the unordered pairs of highest gain the order shown
less often so far is taken (each pair in both orders), then the one that evens the
participant's left and right counts per condition (sides balanced).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

import numpy as np

MIN_CONDITIONS = 8  # the study file's ``design = "adaptive"`` needs this many conditions


@dataclass(frozen=True)
class ScorePosterior:
    """Gaussian posterior over the condition scores (log worth): mean and covariance."""

    mean: np.ndarray
    cov: np.ndarray

    @property
    def sd(self) -> np.ndarray:
        """Posterior standard deviation of each score."""
        return np.sqrt(np.clip(np.diag(self.cov), 0.0, None))

    @property
    def centred_sd(self) -> np.ndarray:
        """Posterior standard deviation of each score minus the mean score: the scale's
        uncertainty without the common shift, which only the prior pins down."""
        n = self.mean.size
        centre = np.eye(n) - 1.0 / n
        return np.sqrt(np.clip(np.diag(centre @ self.cov @ centre), 0.0, None))


def fit_posterior(
    wins: np.ndarray,
    prior_sd: float = 1.0,
    start: np.ndarray | None = None,
    *,
    iterations: int = 50,
) -> ScorePosterior:
    """Laplace approximation of the Bradley-Terry posterior from ``wins[i, j]``, the votes
    preferring i to j (half votes allowed), with independent N(0, prior_sd^2) priors.

    Newton's method on the concave log posterior from ``start`` (a previous mean). Returns the
    mode and the inverse of minus the Hessian there.

    >>> post = fit_posterior(np.array([[0.0, 8.0], [2.0, 0.0]]))
    >>> bool(post.mean[0] > 0 > post.mean[1]), bool(np.all(post.sd < 1.0))
    (True, True)
    """
    wins = np.asarray(wins, dtype=float)
    n = wins.shape[0]
    total = wins + wins.T
    prior = 1.0 / prior_sd**2
    s = np.zeros(n) if start is None else np.array(start, dtype=float)
    for _ in range(iterations):
        q = 1.0 / (1.0 + np.exp(-(s[:, None] - s[None, :])))  # P(i over j)
        grad = (wins - total * q).sum(axis=1) - prior * s
        w = total * q * (1.0 - q)
        hess = np.diag(w.sum(axis=1)) - w + prior * np.eye(n)  # minus the Hessian
        step = np.linalg.solve(hess, grad)
        s = s + step
        if np.abs(step).max() < 1e-9:
            break
    q = 1.0 / (1.0 + np.exp(-(s[:, None] - s[None, :])))
    w = total * q * (1.0 - q)
    hess = np.diag(w.sum(axis=1)) - w + prior * np.eye(n)
    return ScorePosterior(s, np.linalg.inv(hess))


def information_gain(post: ScorePosterior) -> np.ndarray:
    """Expected information gain (nats) of one more vote on each pair: an (n, n) symmetric
    array, 0 on the diagonal (formula in the module docstring).

    >>> gain = information_gain(ScorePosterior(np.array([0.0, 0.0, 4.0]), np.eye(3)))
    >>> bool(gain[0, 1] > gain[0, 2] > 0), float(gain[1, 1])
    (True, 0.0)
    """
    mean, cov = post.mean, post.cov
    var = np.diag(cov)
    m = mean[:, None] - mean[None, :]
    v = np.clip(var[:, None] + var[None, :] - 2.0 * cov, 0.0, None)
    p = 1.0 / (1.0 + np.exp(-m / np.sqrt(1.0 + np.pi * v / 8.0)))
    q = 1.0 / (1.0 + np.exp(-m))
    w = q * (1.0 - q)
    wv = w * v
    base = np.log1p(wv) - wv / (1.0 + wv)
    shift = v / (1.0 + wv) ** 2
    kl_1 = 0.5 * (base + (1.0 - q) ** 2 * shift)
    kl_0 = 0.5 * (base + q**2 * shift)
    gain = p * kl_1 + (1.0 - p) * kl_0
    np.fill_diagonal(gain, 0.0)
    return gain


def next_pair(
    post: ScorePosterior,
    showable: Collection[tuple[int, int]],
    shown: np.ndarray,
    sides: np.ndarray,
    rng: np.random.Generator,
) -> tuple[int, int] | None:
    """The ordered pair (left, right) to show next, or None when nothing can be shown.

    Parameters
    ----------
    post:
        The current posterior over the n scores (:func:`fit_posterior`).
    showable:
        The ordered pairs of different conditions this participant may be shown now (those
        with a rendered clip, less what the study rules out, e.g. pairs already seen).
    shown:
        (n, n) times each ordered pair was shown so far (in the study): the order of the
        chosen pair is the one shown less often, so each pair comes in both orders.
    sides:
        (n,) the participant's left minus right presentations per condition: a tie in the
        above is broken by the order that brings these closer to 0.
    rng:
        Breaks the remaining ties (equal gains to rounding) at random.
    """
    pairs = [(int(i), int(j)) for i, j in showable if i != j]
    if not pairs:
        return None
    gain = information_gain(post)
    values = np.array([gain[i, j] for i, j in pairs])
    best = values.max()
    close = values >= best * (1.0 - 1e-9)
    tied = [pr for pr, near in zip(pairs, close, strict=True) if near]
    unordered = sorted({(min(i, j), max(i, j)) for i, j in tied})
    a, b = unordered[int(rng.integers(len(unordered)))]
    orders = [pr for pr in ((a, b), (b, a)) if pr in set(pairs)]

    def rank(pr: tuple[int, int]) -> tuple[float, float]:
        left, right = pr
        after = np.array(sides, dtype=float)
        after[left] += 1.0
        after[right] -= 1.0
        return float(shown[left, right]), float(np.abs(after[[left, right]]).sum())

    keys = [rank(pr) for pr in orders]
    first = min(keys)
    return orders[int(rng.choice([k for k, key in enumerate(keys) if key == first]))]


def wins_from_votes(n: int, left: np.ndarray, right: np.ndarray, choice: np.ndarray) -> np.ndarray:
    """``wins[i, j]`` from votes: ``choice`` 0 left chosen, 1 right chosen, 2 undecided (half
    to each side); same-condition votes are left out.

    >>> wins_from_votes(2, np.array([0, 1, 0]), np.array([1, 0, 1]), np.array([0, 0, 2]))
    array([[0. , 1.5],
           [1.5, 0. ]])
    """
    left, right, choice = (np.asarray(x, dtype=int) for x in (left, right, choice))
    keep = left != right
    left, right, choice = left[keep], right[keep], choice[keep]
    wins = np.zeros((n, n))
    np.add.at(wins, (left[choice == 0], right[choice == 0]), 1.0)
    np.add.at(wins, (right[choice == 1], left[choice == 1]), 1.0)
    tie = choice == 2
    np.add.at(wins, (left[tie], right[tie]), 0.5)
    np.add.at(wins, (right[tie], left[tie]), 0.5)
    return wins
