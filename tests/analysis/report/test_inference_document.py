"""The participant-level, model and quality blocks of the pair report
(``app.analysis.report.inference_document``): what Table 10 counts is what it says it counts."""

from __future__ import annotations

import pandas as pd

from app.analysis import analyze
from app.analysis.report.blocks import Table
from app.analysis.report.document import build_document

COLUMNS = ["participant", "clip", "left", "right", "choice", "kind", "excluded"]


def _quality_table(rows: list[tuple[str, ...]]) -> Table:
    blocks = build_document(analyze(pd.DataFrame(rows, columns=COLUMNS), bootstrap=0))
    return next(b for b in blocks if isinstance(b, Table) and b.caption.startswith("Table 10"))


def test_identical_pairs_of_the_design_are_not_called_catch_trials():
    """A study without catch trials whose design shows the same condition on both sides: the
    quality table counts those pairs under their own name, and says there was no catch trial."""
    table = _quality_table(
        [
            ("p", "x", "A", "B", "left", "trial", ""),
            ("p", "x", "B", "A", "right", "trial", ""),
            ("p", "x", "A", "A", "left", "trial", ""),
            ("p", "x", "B", "B", "right", "trial", ""),
        ]
    )
    assert "catch" not in " ".join(table.header)
    column = table.header.index("identical undecided")
    assert table.rows[0][column] == "0/2"
    assert "same condition on both sides" in table.note and "not catch trials" in table.note
    assert "The votes hold no catch trial" in table.note


def test_the_catch_trials_left_out_are_counted_apart():
    table = _quality_table(
        [
            ("p", "x", "A", "B", "left", "trial", ""),
            ("p", "x", "B", "A", "right", "trial", ""),
            ("p", "x", "A", "A", "undecided", "catch", ""),
            ("q", "x", "A", "B", "left", "trial", ""),
            ("q", "x", "B", "B", "left", "catch", ""),
        ]
    )
    column = table.header.index("identical undecided")
    assert [row[column] for row in table.rows] == ["-", "-"]  # the catch rows are not in it
    assert "2 catch-trial votes" in table.note
