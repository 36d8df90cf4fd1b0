"""What the answer details say: the 5-level strengths and the reason tags of the votes.

A study on the 5-level scale (``answer.scale = 5``, after the GENEA challenge's HEMVIP2
interface: clearly / slightly left, cannot decide, slightly / clearly right) stores with each
vote a ``strength``: 2 clearly, 1 slightly, 0 cannot decide (``app.trials.participation.
STRENGTHS``). :func:`strength_summary` counts the five levels per pair of conditions, turned
to the pair's first condition: "clearly a" is a vote with strength 2 for the face showing ``a``,
whichever side it was on. Its mean graded score, +2 clearly a ... -2 clearly b, is the
5-point category rating the level counts give (Likert-type; no scale model is fitted to it).

A study offering reason tags (``answer.reasons``) stores the ticked tags with each vote,
``;``-separated. :func:`reason_summary` counts each tag over the votes, by the condition
chosen (undecided votes under "undecided").

Both read the votes the statistics read (no catch trials, no appropriateness pairs, no
excluded participant) and say nothing (None) when no vote carries the detail.

>>> import pandas as pd
>>> votes = pd.DataFrame({"left": ["a", "b", "a"], "right": ["b", "a", "b"],
...                       "choice": ["left", "left", "undecided"], "strength": [2, 1, 0],
...                       "reasons": ["lips;eyes", "lips", ""]})
>>> s = strength_summary(votes, ["a", "b"])
>>> s["pairs"][0]["counts"], s["pairs"][0]["mean"]
([1, 0, 1, 1, 0], 0.3333333333333333)
>>> reason_summary(votes, ["a", "b"])["tags"]["lips"]
{'total': 2, 'a': 1, 'b': 1, 'undecided': 0}
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations
from typing import Any

import numpy as np
import pandas as pd

from app.analysis.json_values import json_number

#: The five levels from the pair's first condition's side, in the order of every count list.
LEVELS: tuple[str, ...] = (
    "clearly first",
    "slightly first",
    "cannot decide",
    "slightly second",
    "clearly second",
)
#: Graded score of each level (+2 clearly the first condition ... -2 clearly the second).
SCORES = np.array([2, 1, 0, -1, -2])


def _strength_column(frame: pd.DataFrame) -> pd.Series:
    if "strength" not in frame:
        return pd.Series(pd.NA, index=frame.index, dtype="Int64")
    return frame["strength"].astype("Int64")


def strength_summary(frame: pd.DataFrame, conditions: Sequence[str]) -> dict[str, Any] | None:
    """Counts of the five levels per pair of different conditions (``conditions`` order: the
    first named is the pair's first) and pooled, with the mean graded score per pair.

    Returns ``{"levels": LEVELS, "pairs": [{"a", "b", "counts", "votes", "mean"}], "pooled":
    counts, "votes": n, "mean": pooled mean}``, counts in :data:`LEVELS` order; None when no
    vote has a strength.
    Votes with a strength outside 0-2, or 0 with a decided choice, are not counted.
    """
    strength = _strength_column(frame)
    rated = frame[strength.notna().to_numpy()]
    if rated.empty:
        return None
    level_of = strength[strength.notna()].to_numpy(dtype=int)
    left = rated["left"].astype(str).to_numpy()
    right = rated["right"].astype(str).to_numpy()
    choice = rated["choice"].astype(str).to_numpy()
    chosen = np.where(choice == "left", left, np.where(choice == "right", right, ""))
    order = {name: i for i, name in enumerate(conditions)}
    pairs = []
    pooled = np.zeros(len(LEVELS), dtype=int)
    for a, b in combinations(
        sorted(set(left) | set(right), key=lambda c: (order.get(c, 1e9), c)), 2
    ):
        here = ((left == a) & (right == b)) | ((left == b) & (right == a))
        counts = np.zeros(len(LEVELS), dtype=int)
        for level, index in ((2, 0), (1, 1)):
            counts[index] = int((here & (chosen == a) & (level_of == level)).sum())
            counts[len(LEVELS) - 1 - index] = int(
                (here & (chosen == b) & (level_of == level)).sum()
            )
        counts[2] = int((here & (choice == "undecided") & (level_of == 0)).sum())
        votes = int(counts.sum())
        if not votes:
            continue
        pooled += counts
        pairs.append(
            {
                "a": a,
                "b": b,
                "counts": [int(c) for c in counts],
                "votes": votes,
                "mean": json_number(float(counts @ SCORES) / votes),
            }
        )
    if not pairs:
        return None
    return {
        "levels": list(LEVELS),
        "pairs": pairs,
        "pooled": [int(c) for c in pooled],
        "votes": int(pooled.sum()),
        "mean": json_number(float(pooled @ SCORES) / int(pooled.sum())),
    }


def _any_text(column: pd.Series) -> bool:
    """Whether any value of ``column`` holds more than blanks (a categorical is judged by
    the categories its rows use: the reader's columns are, and most exports leave reasons
    empty, where making 600,000 strings to find that out took 0.06 s)."""
    if isinstance(column.dtype, pd.CategoricalDtype):
        used = np.unique(column.cat.codes.to_numpy())
        names = column.cat.categories[used[used >= 0]].astype(str)
        return bool((names.str.strip().str.len() > 0).any())
    return bool((column.astype(str).str.strip().str.len() > 0).any())


def reason_summary(frame: pd.DataFrame, conditions: Sequence[str]) -> dict[str, Any] | None:
    """How often each reason tag was ticked, in total and by the condition chosen.

    Returns ``{"tags": {tag: {"total", <condition>..., "undecided"}}, "votes": votes with at
    least one tag, "of": all votes}``, tags by falling total (ties by name); None when no vote
    carries a tag.
    """
    if "reasons" not in frame or frame.empty or not _any_text(frame["reasons"]):
        return None  # no tag on any vote: nothing to count
    reasons = frame["reasons"].astype(str)
    choice = frame["choice"].astype(str).to_numpy()
    chosen = np.where(
        choice == "left",
        frame["left"].astype(str).to_numpy(),
        np.where(choice == "right", frame["right"].astype(str).to_numpy(), "undecided"),
    )
    columns = [*conditions, "undecided"]
    tally: dict[str, dict[str, int]] = {}
    with_tags = 0
    # each distinct (reasons, chosen) once, with its count: a few dozen, not one per vote
    combos = pd.DataFrame({"reasons": reasons.to_numpy(), "who": chosen})
    for (text, who), count in combos.value_counts(sort=False).items():
        tags = [t.strip() for t in str(text).split(";") if t.strip()]
        with_tags += int(count) if tags else 0
        for tag in dict.fromkeys(tags):
            row = tally.setdefault(tag, {"total": 0, **dict.fromkeys(columns, 0)})
            row["total"] += int(count)
            row[who] = row.get(who, 0) + int(count)
    if not tally:
        return None
    ranked = sorted(tally.items(), key=lambda item: (-item[1]["total"], item[0]))
    return {"tags": dict(ranked), "votes": with_tags, "of": len(frame)}
