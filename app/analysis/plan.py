"""Planning a study: power of the planned tests and expected interval widths, by simulation.

"How many participants do I need?" Studies are drawn from the Bradley-Terry-Davidson model of
:mod:`app.analysis.btd` with assumed scores (in JOD, or fitted to pilot votes), a side factor
g and a tie parameter nu. Each participant answers ``votes`` trials that cycle through the
design's pairs: ``all_ordered`` shows every ordered pair (both sides of each pair, thesis
TABLE 3), ``unordered`` every unordered pair with a random side. Each simulated study is
analysed as the report analyses real votes:

- ``wilcoxon``: the participant-level Wilcoxon signed-rank test of each pair
  (:mod:`app.analysis.participant_level`), Holm-adjusted over the pairs;
- ``sign_per_participant``: the sign test with one judgement per participant and pair;
- ``sign_pooled``: the pooled sign test of every presentation (its error rate is not
  controlled when participants judge a pair repeatedly; listed for comparison).

Power is the share of simulated studies in which the Holm-adjusted p is below ``alpha``. The
expected width of a score's interval is the central ``confidence`` range of the model's
scores (in JOD) over the simulated studies: the width a bootstrap interval estimates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from app.analysis.btd import JOD_PER_LOG_WORTH, fit_btd_many
from app.analysis.participant_level import net_preference, pair_counts
from app.analysis.signed_rank import signed_rank_p
from app.analysis.signtest import sign_test_p
from app.analysis.ttest import holm
from app.errors import InputError

PLAN_DESIGNS = ("all_ordered", "unordered")
PLANNED_TESTS = ("wilcoxon", "sign_per_participant", "sign_pooled")


@dataclass(frozen=True)
class StudyPlan:
    """What is assumed about the study: conditions, their scores in JOD, g, nu and the design."""

    conditions: tuple[str, ...]
    jod: tuple[float, ...]
    gamma: float = 1.0
    nu: float = 0.4
    design: str = "all_ordered"
    votes: int | None = None  # per participant; default one pass through the design
    source: str = "assumed"
    notes: list[str] = field(default_factory=list)

    def trials(self) -> tuple[np.ndarray, np.ndarray]:
        """(left, right) condition indices of one pass through the design's pairs."""
        n = len(self.conditions)
        i, j = np.triu_indices(n, 1)
        if self.design == "all_ordered":
            return np.concatenate([i, j]), np.concatenate([j, i])
        return i, j

    def check(self) -> None:
        if len(self.conditions) < 2 or len(self.jod) != len(self.conditions):
            raise InputError("give a score for each of at least two conditions", field="effects")
        if self.design not in PLAN_DESIGNS:
            raise InputError(
                f"expected one of {', '.join(PLAN_DESIGNS)}, got {self.design!r}", field="design"
            )
        if not (self.gamma > 0 and np.isfinite(self.gamma)):
            raise InputError(f"must be a number > 0, got {self.gamma}", field="gamma")
        if not (self.nu >= 0 and np.isfinite(self.nu)):
            raise InputError(f"must be a number >= 0, got {self.nu}", field="nu")
        pairs = len(self.trials()[0])
        if self.votes is not None and self.votes < pairs:
            raise InputError(
                f"{self.votes} votes per participant do not reach every pair of the "
                f"design once ({pairs} needed)",
                field="votes-per-participant",
            )


def simulate_counts(
    plan: StudyPlan, participants: int, simulations: int, rng: np.random.Generator
) -> np.ndarray:
    """(simulations, participants, n, n, 3) vote counts drawn from the model."""
    n = len(plan.conditions)
    left, right = plan.trials()
    votes = plan.votes or len(left)
    k = np.arange(votes) % len(left)
    shape = (simulations, participants, votes)
    li, ri = np.broadcast_to(left[k], shape).copy(), np.broadcast_to(right[k], shape).copy()
    if plan.design == "unordered":
        swap = rng.random(shape) < 0.5
        li, ri = np.where(swap, ri, li), np.where(swap, li, ri)
    pi = np.exp(np.asarray(plan.jod) / JOD_PER_LOG_WORTH)
    weights = np.stack([plan.gamma * pi[li], pi[ri], plan.nu * np.sqrt(pi[li] * pi[ri])], -1)
    cum = np.cumsum(weights, axis=-1)
    u = rng.random(shape) * cum[..., -1]
    outcome = (u[..., None] >= cum[..., :-1]).sum(axis=-1)
    unit = np.arange(simulations * participants).reshape(simulations, participants, 1)
    flat = ((unit * n + li) * n + ri) * 3 + outcome
    return np.bincount(flat.ravel(), minlength=simulations * participants * n * n * 3).reshape(
        simulations, participants, n, n, 3
    )


def _holm_rows(p: np.ndarray) -> np.ndarray:
    return np.apply_along_axis(holm, -1, p)


def _powers(counts: np.ndarray, alpha: float) -> dict[str, np.ndarray]:
    """Per planned test, (pairs,) share of studies with Holm-adjusted p < alpha."""
    s, p, n = counts.shape[:3]
    flat = counts.reshape(s * p, n, n, 3)
    d = net_preference(flat).reshape(s, p, -1)
    wil = np.column_stack([signed_rank_p(d[:, :, q]) for q in range(d.shape[2])])
    wa, wb, _ = (x.reshape(s, p, -1) for x in pair_counts(flat))
    per = sign_test_p((wa > wb).sum(axis=1), (wb > wa).sum(axis=1))
    pooled = sign_test_p(wa.sum(axis=1), wb.sum(axis=1))
    out = {}
    for name, values in zip(PLANNED_TESTS, (wil, per, pooled), strict=True):
        adjusted = _holm_rows(np.where(np.isnan(values), 1.0, values))
        out[name] = (adjusted < alpha).mean(axis=0)
    return out


def plan_study(
    plan: StudyPlan,
    participants: Sequence[int],
    *,
    simulations: int = 1000,
    alpha: float = 0.05,
    confidence: float = 0.95,
    seed: int = 0,
) -> dict[str, Any]:
    """Power of each planned test per pair, and expected interval widths, per participant count.

    >>> r = plan_study(StudyPlan(("a", "b"), (0.0, 1.0), votes=10), [20], simulations=200)
    >>> r["levels"][0]["power"]["wilcoxon"]["a vs b"] > 0.8
    True
    """
    plan.check()
    if not participants or min(participants) < 2:
        raise InputError("plan for at least 2 participants", field="participants")
    if not 0 < alpha < 1 or not 0 < confidence < 1:
        raise InputError("alpha and confidence must lie between 0 and 1", field="alpha")
    names = plan.conditions
    i, j = np.triu_indices(len(names), 1)
    labels = [f"{names[a]} vs {names[b]}" for a, b in zip(i, j, strict=True)]
    rng = np.random.default_rng(seed)
    levels = []
    tail = (1.0 - confidence) / 2.0 * 100.0
    for count in sorted(set(int(c) for c in participants)):
        counts = simulate_counts(plan, count, simulations, rng)
        power = _powers(counts, alpha)
        beta, ok = fit_btd_many(counts.sum(axis=1))
        jod = beta[ok, : len(names)] * JOD_PER_LOG_WORTH
        widths: dict[str, float | None]
        if ok.sum() >= 10:
            low, high = np.percentile(jod, [tail, 100.0 - tail], axis=0)
            widths = {c: float(w) for c, w in zip(names, high - low, strict=True)}
        else:
            widths = {c: None for c in names}
        levels.append(
            {
                "participants": count,
                "power": {
                    t: dict(zip(labels, map(float, power[t]), strict=True)) for t in PLANNED_TESTS
                },
                "ci_width_jod": widths,
                "fits_converged": int(ok.sum()),
            }
        )
    truth = np.asarray(plan.jod) - np.mean(plan.jod)
    return {
        "conditions": list(names),
        "jod": dict(zip(names, map(float, truth), strict=True)),
        "gamma": plan.gamma,
        "nu": plan.nu,
        "design": plan.design,
        "votes_per_participant": plan.votes or len(plan.trials()[0]),
        "simulations": simulations,
        "alpha": alpha,
        "confidence": confidence,
        "seed": seed,
        "source": plan.source,
        "notes": list(plan.notes),
        "levels": levels,
    }


def plan_from_pilot(
    counts: np.ndarray,
    conditions: Sequence[str],
    *,
    design: str = "all_ordered",
    votes: int | None = None,
    source: str = "pilot",
) -> StudyPlan:
    """A plan whose scores, g and nu are the model fitted to pilot votes (n, n, 3) pooled."""
    from app.analysis.btd import fit_btd

    fit = fit_btd(counts)
    if not fit.converged:
        raise InputError(f"the pilot votes give no model to plan from: {fit.note}", path=source)
    return StudyPlan(
        tuple(conditions),
        tuple(float(v) for v in fit.theta * JOD_PER_LOG_WORTH),
        gamma=fit.gamma,
        nu=fit.nu,
        design=design,
        votes=votes,
        source=source,
        notes=[f"fitted to {fit.votes} pilot votes (identical pairs left out)"],
    )
