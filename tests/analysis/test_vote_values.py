import numpy as np
import pandas as pd
import pytest

from app.analysis import csv_blocks
from app.analysis.vote_values import type_block, without_bad_rows
from app.analysis.votes import COLUMN_SPECS, read_votes
from app.errors import InputError


def _write(tmp_path, text, name="votes.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _column(*values):
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


def test_a_rows_problem_is_its_first_bad_column_and_a_known_one_wins():
    columns = {
        "participant": _column("p", "", "p", "", "p"),
        "clip": _column("s", "s", "s", "", "s"),
        "left": _column("a", "a", "a", "", "c"),
        "right": _column("b", "b", "b", "", "b"),
        "choice": _column("left", "maybe", "Right", "", "left"),
        "plays": _column("1", "x", "", "", "2"),
        "extra": _column("", "", "", "", "anything"),
    }
    lines = np.array([2, 3, -4, 5, 6])
    known = {2: InputError("expected 6 fields like the header, got 7", line=4)}
    block = type_block(
        columns, lines, COLUMN_SPECS, strip=True, path=None, conditions=["a", "b"], known=known
    )
    assert block.lines.tolist() == [2, 3, 4, 5, 6] and block.blank.tolist() == [0, 0, 0, 1, 0]
    assert sorted(block.problems) == [1, 2, 4]
    assert (block.problems[1].field, block.problems[1].message) == ("participant", "missing value")
    assert block.problems[2] is known[2]
    assert block.problems[4].field == "left" and "unknown condition 'c'" in str(block.problems[4])
    kept = without_bad_rows(block)
    codes, choices = kept.values["choice"]
    assert codes.tolist() == [0] and choices.tolist() == [0, -1, 1, -1]


@pytest.mark.parametrize(
    ("column", "value", "what"),
    [
        ("trial", "1.5", "whole number"),
        ("trial", "-1", "whole number"),
        ("plays", "x", "whole number"),
        ("response_ms", "fast", "a number"),
        ("voted_at", "yesterday", "ISO 8601"),
    ],
)
def test_optional_columns_are_typed(tmp_path, column, value, what):
    path = _write(tmp_path, f"participant,clip,left,right,choice,{column}\np,c,a,b,left,{value}\n")
    with pytest.raises(InputError, match=what) as err:
        read_votes(path)
    assert err.value.field == column and err.value.line == 2


@pytest.mark.parametrize("value", ["inf", "1e300", "nan"])
def test_a_count_that_is_not_a_finite_whole_number_is_a_bad_row(tmp_path, value):
    path = _write(tmp_path, f"participant,clip,left,right,choice,trial\np,c,a,b,left,{value}\n")
    with pytest.raises(InputError, match="whole number") as err:
        read_votes(path)
    assert err.value.line == 2 and err.value.field == "trial"


def test_a_quoted_time_is_read_unquoted(tmp_path, monkeypatch):
    """Arrow reads with quoting off; a quoted time must not reach the time rule with its
    quotes on but go to the exact reader, which unquotes it."""
    monkeypatch.setattr(csv_blocks, "BLOCK_BYTES", 64)
    rows = ["p,s,a,b,left,2026-03-02T09:00:00Z"] * 12 + ['p,s,a,b,right,"2026-03-02T10:00:00Z"']
    header = "participant,clip,left,right,choice,voted_at\n"
    t = read_votes(_write(tmp_path, header + "\n".join(rows) + "\n"))
    assert len(t) == 13 and str(t.frame["voted_at"].iloc[-1]) == "2026-03-02 10:00:00+00:00"


@pytest.mark.parametrize(
    "value", ["2026-03-02 09:00:00", " 2026-03-02T09:00:00Z", "2026-03-02T09:00:00.1234567Z"]
)
def test_times_arrows_parser_refuses_take_the_full_rule(tmp_path, value):
    path = _write(tmp_path, f"participant,clip,left,right,choice,voted_at\np,s,a,b,left,{value}\n")
    when = read_votes(path).frame["voted_at"].iloc[0]
    assert when == pd.Timestamp(value.strip(), tz="UTC").floor("us")  # the frame holds us
