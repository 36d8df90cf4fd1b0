"""Ratings tables whose answers are known, for the analysis of ratings and its report
(``tests/analysis/``): ACR ratings with known condition means, and a parallel test in which one
participant misses the hidden reference. Nothing here is part of the application."""

from __future__ import annotations

import numpy as np

#: The condition means :func:`acr_rows` draws its scores about.
TRUE_MOS = {"none": 2.0, "random": 3.0, "ground_truth": 4.5}


def acr_rows(n_participants: int = 12, seed: int = 3) -> list[dict]:
    """ACR-like ratings with known condition means, participant and clip offsets, noise."""
    rng = np.random.default_rng(seed)
    person = rng.normal(0, 0.3, n_participants)
    clip = {"s2": -0.2, "s7": 0.2}
    rows = []
    for p in range(n_participants):
        for k, offset in clip.items():
            for c, mu in TRUE_MOS.items():
                score = int(np.clip(np.rint(mu + person[p] + offset + rng.normal(0, 0.4)), 1, 5))
                rows.append(
                    {
                        "participant": f"P{p:02d}",
                        "clip": k,
                        "condition": c,
                        "score": score,
                        "scale": "acr5",
                        "kind": "trial",
                        "excluded": "",
                    }
                )
        rows.append(
            {
                "participant": f"P{p:02d}",
                "clip": "s2",
                "condition": "none",
                "score": 1 if p else 4,
                "scale": "acr5",
                "kind": "catch",
                "excluded": "",
            }
        )
    # a participant the export marks excluded, rating everything Excellent
    for k in clip:
        for c in TRUE_MOS:
            rows.append(
                {
                    "participant": "PX",
                    "clip": k,
                    "condition": c,
                    "score": 5,
                    "scale": "acr5",
                    "kind": "trial",
                    "excluded": "failed a catch trial",
                }
            )
    return rows


def parallel_rows() -> list[dict]:
    """Four participants x four clips of a parallel test; P03 rates the hidden reference 60
    on one clip in four (25 % > 15 %), P02 on none."""
    rows = []
    for p in range(4):
        for k in range(4):
            for item, (c, score) in enumerate((("gt", 95), ("a", 40 + 10 * p), ("b", 70))):
                if c == "gt" and p == 3 and k == 0:
                    score = 60
                rows.append(
                    {
                        "participant": f"P{p:02d}",
                        "clip": f"s{k}",
                        "condition": c,
                        "item": item + 1,
                        "reference": c == "gt",
                        "score": score,
                        "scale": "slider",
                        "kind": "trial",
                    }
                )
    return rows
