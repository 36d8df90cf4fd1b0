"""Adaptive against full pair designs, by simulation: votes needed for the same accuracy.

Studies are drawn from the Bradley-Terry-Davidson model (:mod:`app.analysis.btd`, side factor
1) with known scores evenly spaced over ``spread_jod`` JOD. Votes arrive participant after
participant:

- ``full``: each participant judges every ordered pair of different conditions once, in a
  random order (the ``all_ordered`` design without its same-condition pairs);
- ``adaptive``: each participant casts ``n (n - 1) / 2`` votes, each on the pair of highest
  expected information gain under the posterior of all votes so far
  (:func:`app.trials.adaptive.next_pair`, ASAP, Mikhailiuk et al. 2021), never the same ordered
  pair twice for one participant, orders and sides balanced as the study does.

Every ``n`` votes the accuracy of the scale is measured on the same estimator for both (the
Laplace posterior of :func:`app.trials.adaptive.fit_posterior`): Kendall's tau and Spearman's
rho between the posterior mean and the true scores, and the mean width of the 95 % intervals
in JOD (of the scores centred to mean 0). The answer is the number of votes each design
needs, on the mean over simulations, to reach the accuracy the full design has after
``passes`` participants.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from app.analysis.btd import JOD_PER_LOG_WORTH
from app.trials.adaptive import fit_posterior, next_pair

METRICS = ("kendall", "spearman", "ci_width_jod")


@dataclass(frozen=True)
class AdaptivePlan:
    """The simulated study: conditions, the true scores' spread, ties and votes."""

    conditions: int = 8
    spread_jod: float = 3.0
    nu: float = 0.4
    participants: int = 6  # full-design participants: n (n - 1) votes each
    simulations: int = 40
    prior_sd: float = 2.0

    def truth(self) -> np.ndarray:
        """True scores in log worth, mean 0."""
        jod = np.linspace(0.0, self.spread_jod, self.conditions)
        return (jod - jod.mean()) / JOD_PER_LOG_WORTH


def _answer(theta: np.ndarray, left: int, right: int, nu: float, rng: np.random.Generator) -> int:
    """0 left chosen, 1 right chosen, 2 undecided (Davidson 1970, g = 1)."""
    a, b = np.exp(theta[left]), np.exp(theta[right])
    p = np.array([a, b, nu * np.sqrt(a * b)])
    return int(rng.choice(3, p=p / p.sum()))


def _credit(wins: np.ndarray, left: int, right: int, answer: int) -> None:
    if answer == 0:
        wins[left, right] += 1.0
    elif answer == 1:
        wins[right, left] += 1.0
    else:
        wins[left, right] += 0.5
        wins[right, left] += 0.5


def _accuracy(wins: np.ndarray, truth: np.ndarray, prior_sd: float) -> list[float]:
    post = fit_posterior(wins, prior_sd)
    tau = stats.kendalltau(post.mean, truth).statistic
    rho = stats.spearmanr(post.mean, truth).statistic
    width = float(np.mean(2 * 1.959964 * post.centred_sd)) * JOD_PER_LOG_WORTH
    return [float(tau), float(rho), width]


def simulate_design(plan: AdaptivePlan, design: str, rng: np.random.Generator) -> np.ndarray:
    """Accuracy after every n votes of one simulated study: (checkpoints, 3) with Kendall's
    tau, Spearman's rho and the mean 95 % interval width (JOD)."""
    n, theta = plan.conditions, plan.truth()
    total = plan.participants * n * (n - 1)
    ordered = [(i, j) for i in range(n) for j in range(n) if i != j]
    wins = np.zeros((n, n))
    shown = np.zeros((n, n))
    out: list[list[float]] = []
    votes = 0
    post = fit_posterior(wins, plan.prior_sd)
    while votes < total:
        if design == "full":
            queue = [ordered[k] for k in rng.permutation(len(ordered))]
        else:
            queue = []
        seen: set[tuple[int, int]] = set()
        sides = np.zeros(n)
        budget = len(ordered) if design == "full" else len(ordered) // 2
        for step in range(budget):
            if votes >= total:
                break
            if design == "full":
                left, right = queue[step]
            else:
                choice = next_pair(post, [p for p in ordered if p not in seen], shown, sides, rng)
                assert choice is not None
                left, right = choice
            seen.add((left, right))
            sides[left] += 1
            sides[right] -= 1
            shown[left, right] += 1
            _credit(wins, left, right, _answer(theta, left, right, plan.nu, rng))
            votes += 1
            if design != "full":
                post = fit_posterior(wins, plan.prior_sd, start=post.mean, iterations=3)
            if votes % n == 0:
                out.append(_accuracy(wins, theta, plan.prior_sd))
    return np.asarray(out)


def _votes_to_reach(curve: np.ndarray, target: float, n: int, higher: bool) -> float | None:
    """The first vote count (interpolated between checkpoints every n votes) at which the
    mean curve reaches ``target``; None if it never does."""
    ok = curve >= target if higher else curve <= target
    if not ok.any():
        return None
    k = int(np.argmax(ok))
    if k == 0:
        return float(n)
    a, b = curve[k - 1], curve[k]
    frac = 1.0 if a == b else (target - a) / (b - a)
    return float(n * (k + frac))


def compare_designs(plan: AdaptivePlan, *, passes: int = 3, seed: int = 0) -> dict[str, Any]:
    """Mean accuracy curves of both designs and the votes each needs to reach the full
    design's accuracy after ``passes`` participants (each metric on its own)."""
    rng = np.random.default_rng(seed)
    n = plan.conditions
    curves = {
        d: np.mean([simulate_design(plan, d, rng) for _ in range(plan.simulations)], axis=0)
        for d in ("full", "adaptive")
    }
    at = passes * (n - 1) - 1  # the checkpoint after ``passes`` full participants
    reached: dict[str, Any] = {}
    for k, metric in enumerate(METRICS):
        target = float(curves["full"][at, k])
        higher = metric != "ci_width_jod"
        reached[metric] = {
            "target": target,
            "full": _votes_to_reach(curves["full"][:, k], target, n, higher),
            "adaptive": _votes_to_reach(curves["adaptive"][:, k], target, n, higher),
        }
    return {
        "conditions": n,
        "spread_jod": plan.spread_jod,
        "nu": plan.nu,
        "simulations": plan.simulations,
        "passes": passes,
        "full_votes": passes * n * (n - 1),
        "reached": reached,
        "curves": {d: c.tolist() for d, c in curves.items()},
        "checkpoint_votes": n,
    }
