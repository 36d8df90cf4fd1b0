"""Simulated paired-comparison studies with known truth, for examples, tests and benchmarks.

Every participant sees every ordered pair of conditions (the thesis's 4 x 4 design, sec. 5.2,
same-condition pairs included) on every clip, in a random order. A judgement follows Thurstone
Case V: the latent difference z = s_left - s_right + sigma * e, e ~ N(0, 1), sigma = 1.4826 (so
a true difference of 1 JOD gives 75 % preference when nobody abstains); the participant answers
``undecided`` when |z| < ``undecided_width`` and otherwise picks the side z favours.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from app.analysis.scaling import JOD_SIGMA


def simulate_votes(
    true_scale: Mapping[str, float],
    *,
    participants: int = 20,
    clips: Sequence[str] = ("s2", "s7"),
    undecided_width: float = 0.3,
    seed: int = 0,
    study: str = "simulated",
) -> pd.DataFrame:
    """A votes frame (columns of :data:`app.analysis.votes.VOTE_COLUMNS`) from a known scale.

    >>> v = simulate_votes({"a": 0.0, "b": 1.0}, participants=3, clips=("c",))
    >>> len(v), sorted(set(v["choice"])) <= ["left", "right", "undecided"]
    (12, True)
    """
    rng = np.random.default_rng(seed)
    names = list(true_scale)
    values = np.array([true_scale[c] for c in names], dtype=float)
    n = len(names)
    left, right = (g.ravel() for g in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
    per_part = len(clips) * left.size
    clip_idx = np.repeat(np.arange(len(clips)), left.size)
    rows = []
    for p in range(participants):
        order = rng.permutation(per_part)
        li, ri, ci = (
            np.tile(left, len(clips))[order],
            np.tile(right, len(clips))[order],
            clip_idx[order],
        )
        z = values[li] - values[ri] + JOD_SIGMA * rng.standard_normal(per_part)
        choice = np.where(
            np.abs(z) < undecided_width, "undecided", np.where(z > 0, "left", "right")
        )
        start = pd.Timestamp("2026-03-02T09:00:00Z") + pd.Timedelta(minutes=37 * p)
        response = rng.gamma(4.0, 1500.0, per_part).round()
        elapsed = np.cumsum(response + 9000.0)
        rows.append(
            pd.DataFrame(
                {
                    "participant": f"P{p + 1:03d}",
                    "clip": np.asarray(clips, dtype=object)[ci],
                    "left": np.asarray(names, dtype=object)[li],
                    "right": np.asarray(names, dtype=object)[ri],
                    "choice": choice,
                    "study": study,
                    "trial": np.arange(1, per_part + 1),
                    "response_ms": response,
                    "plays": 1 + rng.poisson(0.4, per_part),
                    "presented_at": start + pd.to_timedelta(elapsed - response, unit="ms"),
                    "voted_at": start + pd.to_timedelta(elapsed, unit="ms"),
                }
            )
        )
    return pd.concat(rows, ignore_index=True)
