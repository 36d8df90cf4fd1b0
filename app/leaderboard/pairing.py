"""A round's pairs: which systems are compared, chosen by expected information gain (ASAP).

A round compares the queued newcomers with anchors (the season's fixed anchors, in every round,
and the current top systems). Comparing everything with everything costs C(n, 2) pairs per
segment; most of them between anchors whose order the earlier rounds already settled. The
plan keeps two kinds of pairs:

1. **drift links**: each anchor against the next one on the earlier board (by score), so the
   anchors' differences are measured again in every round (the drift check,
   :func:`app.leaderboard.scores.drift_check`, compares them with the earlier rounds');
2. the rest of the budget by **ASAP** (Mikhailiuk et al. 2021; :mod:`app.trials.adaptive`):
   the Bradley-Terry posterior of every earlier round's votes (a newcomer has none: its prior
   N(0, 1.5^2) is wide, so its pairs gain most), then, greedily, the pair of highest expected
   information gain, the posterior updated by that pair's expected Fisher information for
   ``votes_per_pair`` votes (the batch form of ASAP: the answers are not known yet, the
   covariance shrinks by what they will tell on average), and so on. Newcomers meet anchors
   and systems of about their strength first; pairs of two settled anchors come last.

The study then shows every planned pair on every round segment, in both orders across the
counterbalancing lists (``app.web.board.rounds``).

>>> plan = plan_pairs(["gt", "none", "new"], np.zeros((3, 3)), newcomers=["new"],
...                   anchors=["gt", "none"], budget=2)
>>> [(p.first, p.second, p.reason) for p in plan]
[('gt', 'none', 'drift link'), ('gt', 'new', 'information gain')]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from math import comb

import numpy as np

from app.trials.adaptive import ScorePosterior, fit_posterior, information_gain

#: Prior sd of a score (log worth) in the plan: a newcomer may lie anywhere on a board whose
#: anchors span a few units.
PRIOR_SD = 1.5
#: Votes one planned pair is expected to gather in a round (a round's participants times its
#: segments, for a board of ten or so systems): how far each choice shrinks the posterior.
VOTES_PER_PAIR = 20.0


@dataclass(frozen=True, slots=True)
class PlannedPair:
    """One unordered pair of the round, why it is there and its expected gain when chosen."""

    first: str
    second: str
    reason: str  # "drift link" or "information gain"
    gain: float


def pair_budget(n_systems: int, configured: int = 0) -> int:
    """Unordered pairs a round compares: ``configured`` (the season's ``[rounds] pairs``) or,
    when 0, every pair up to seven systems and three per system beyond (each system against six
    others on average), never more than C(n, 2).

    >>> pair_budget(5), pair_budget(14), pair_budget(14, configured=20)
    (10, 42, 20)
    """
    total = comb(n_systems, 2)
    if configured:
        return min(total, configured)
    return min(total, max(3 * n_systems, 0))


def _update(post: ScorePosterior, i: int, j: int, votes: float) -> ScorePosterior:
    """The posterior after ``votes`` answers on (i, j) of unknown outcome: the mean stays, the
    precision grows by their expected Fisher information ``votes q (1 - q) d d'``."""
    n = post.mean.size
    d = np.zeros(n)
    d[i], d[j] = 1.0, -1.0
    q = 1.0 / (1.0 + np.exp(-(post.mean[i] - post.mean[j])))
    precision = np.linalg.inv(post.cov) + votes * q * (1.0 - q) * np.outer(d, d)
    return ScorePosterior(post.mean, np.linalg.inv(precision))


def plan_pairs(
    systems: Sequence[str],
    prior_wins: np.ndarray,
    *,
    newcomers: Sequence[str],
    anchors: Sequence[str],
    budget: int,
    votes_per_pair: float = VOTES_PER_PAIR,
) -> list[PlannedPair]:
    """The round's pairs in the order they were chosen.

    Parameters
    ----------
    systems:
        Every system of the round, in a fixed order (ties in gain go to the earlier pair).
    prior_wins:
        (n, n) judgements of i over j in the earlier rounds (undecided votes as halves), in
        the order of ``systems``; zeros in the first round.
    newcomers, anchors:
        Which systems are new this round and which are anchors (the drift links join the
        anchors in the order of their earlier scores).
    budget:
        Unordered pairs to plan (:func:`pair_budget`); the drift links count in it.
    """
    names = list(systems)
    n = len(names)
    index = {s: k for k, s in enumerate(names)}
    post = fit_posterior(np.asarray(prior_wins, dtype=float), prior_sd=PRIOR_SD)
    chosen: list[PlannedPair] = []
    taken: set[frozenset[int]] = set()
    known = [a for a in anchors if a in index and a not in set(newcomers)]
    by_score = sorted(known, key=lambda a: (-post.mean[index[a]], index[a]))
    for a, b in zip(by_score, by_score[1:], strict=False):
        if len(chosen) >= budget:
            break
        i, j = sorted((index[a], index[b]))
        gain = float(information_gain(post)[i, j])
        chosen.append(PlannedPair(names[i], names[j], "drift link", gain))
        taken.add(frozenset((i, j)))
        post = _update(post, i, j, votes_per_pair)
    while len(chosen) < min(budget, n * (n - 1) // 2):
        gains = information_gain(post)
        for pair in taken:
            i, j = tuple(pair)
            gains[i, j] = gains[j, i] = -1.0
        upper = np.triu(gains, 1) + np.tril(np.full((n, n), -1.0))
        flat = int(np.argmax(upper))
        i, j = divmod(flat, n)
        if upper[i, j] < 0:
            break
        chosen.append(PlannedPair(names[i], names[j], "information gain", float(upper[i, j])))
        taken.add(frozenset((i, j)))
        post = _update(post, i, j, votes_per_pair)
    return chosen
