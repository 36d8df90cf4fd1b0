"""The appropriateness test: does a condition's motion belong to its speech?

GENEA's appropriateness test shows the same motion model once with the speech it was made for
and once with another clip's speech. In facepair's side-by-side form, an appropriateness pair
plays one clip's speech under two faces of the same condition: one moves with the motion made
for this speech, the other (the ``mismatched`` side) with the motion made for another clip,
time-aligned and trimmed. Per condition, the share of decided votes for the matched face and an
exact two-sided sign test against 1/2 (:func:`app.analysis.signtest.sign_test_p`) say whether
participants can tell; undecided votes are reported, not counted (Le, Ma & Deng 2012, sec. 8.1).

>>> import pandas as pd
>>> rows = pd.DataFrame({"participant": ["p"] * 3, "clip": ["s2"] * 3, "left": ["a"] * 3,
...                      "right": ["a"] * 3, "choice": ["left", "left", "right"],
...                      "mismatched": ["right", "right", "left"]})
>>> appropriateness(rows)["a"]["matched"]
3
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from app.analysis.json_values import json_number
from app.analysis.signtest import sign_test_p
from app.analysis.votes import VotesTable


def _is_pair(frame: pd.DataFrame) -> pd.Series:
    if "mismatched" not in frame:
        return pd.Series(False, index=frame.index)
    side = frame["mismatched"]
    if isinstance(side.dtype, pd.CategoricalDtype):  # the reader's: test each category once
        hit = side.cat.categories.astype(str).str.strip().isin(("left", "right"))
        codes = side.cat.codes.to_numpy()
        return pd.Series(np.where(codes >= 0, hit[codes], False), index=frame.index)
    return side.astype(str).str.strip().isin(("left", "right"))


def without_appropriateness(table: VotesTable) -> VotesTable:
    """The table without appropriateness pairs (for the pair comparisons)."""
    keep = ~_is_pair(table.frame)
    if keep.all():
        return table
    return VotesTable(
        table.frame[keep].reset_index(drop=True), table.skipped, table.problems, table.source
    )


def appropriateness(frame: pd.DataFrame) -> dict[str, dict[str, Any]]:
    """Per condition: votes for the matched and the mismatched face, undecided ones, the
    matched share of decided votes and its sign-test p. Empty without appropriateness pairs."""
    pairs = frame[_is_pair(frame)]
    out: dict[str, dict[str, Any]] = {}
    for condition, rows in pairs.groupby("left", sort=True):
        matched = int(
            (
                (rows["choice"].astype(str) != rows["mismatched"].astype(str).str.strip())
                & rows["choice"].isin(("left", "right"))
            ).sum()
        )
        undecided = int((rows["choice"] == "undecided").sum())
        mismatched = len(rows) - matched - undecided
        decided = matched + mismatched
        out[str(condition)] = {
            "matched": matched,
            "mismatched": mismatched,
            "undecided": undecided,
            "matched_share": json_number(matched / decided) if decided else None,
            "p": json_number(float(sign_test_p(matched, mismatched))) if decided else None,
        }
    return out
