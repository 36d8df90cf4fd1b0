"""Fixtures of the analysis tests: published paired-comparison matrices and votes built from
count matrices."""

from __future__ import annotations

from pathlib import Path

import pytest

ANALYSIS_DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture
def analysis_data() -> Path:
    """Published paired-comparison matrices (tests/analysis/data/README.md)."""
    return ANALYSIS_DATA


def votes_from_matrix(counts, names=None, clip="c1"):
    """A votes frame whose pooled preference counts equal ``counts`` (rows beat columns).

    Judge k of a pair (i, j) is participant ``J{k}``; sides alternate so both orders occur.
    """
    import numpy as np
    import pandas as pd

    counts = np.asarray(counts, dtype=int)
    n = counts.shape[0]
    names = names or [f"c{i:02d}" for i in range(n)]
    rows = []
    for i in range(n):
        for j in range(i + 1, n):
            judges = ["i"] * counts[i, j] + ["j"] * counts[j, i]
            for k, winner in enumerate(judges):
                left, right = (i, j) if k % 2 == 0 else (j, i)
                chosen = i if winner == "i" else j
                rows.append(
                    {
                        "participant": f"J{k:03d}",
                        "clip": clip,
                        "left": names[left],
                        "right": names[right],
                        "choice": "left" if chosen == left else "right",
                    }
                )
    return pd.DataFrame(rows)


@pytest.fixture
def matrix_votes():
    return votes_from_matrix
