"""Votes whose answers (strength and reason tags) are known, for the summaries of the answer
details and their report section (``tests/analysis/``). Nothing here is part of the
application."""

from __future__ import annotations

import pandas as pd

#: (left, right, choice, strength, reasons): a vs b and b vs a, both presentation orders.
VOTES = [
    ("a", "b", "left", 2, "lips;eyes"),  # clearly a
    ("b", "a", "right", 2, "lips"),  # clearly a, shown on the right
    ("a", "b", "left", 1, ""),  # slightly a
    ("b", "a", "left", 1, "head"),  # slightly b
    ("a", "b", "undecided", 0, "eyes"),  # cannot decide
    ("a", "c", "right", 2, "lips"),  # clearly c
]


def answer_frame(rows=VOTES, participant="p1"):
    """The votes ``rows`` (as in :data:`VOTES`) of ``participant`` on clip ``s1``, as the
    table of votes the analysis reads."""
    return pd.DataFrame(
        [
            {
                "participant": participant,
                "clip": "s1",
                "left": left,
                "right": right,
                "choice": choice,
                "strength": strength,
                "reasons": reasons,
            }
            for left, right, choice, strength, reasons in rows
        ]
    )
