import numpy as np
import pandas as pd
import pytest

from app.analysis.counts import ballots, count_votes
from app.analysis.votes import read_votes
from app.errors import InputError


def _table(rows):
    return read_votes(
        pd.DataFrame(rows, columns=["participant", "clip", "left", "right", "choice"])
    )


def test_tensor_and_ballots_by_hand():
    t = _table(
        [
            ("p1", "s2", "A", "B", "left"),
            ("p1", "s2", "B", "A", "left"),
            ("p1", "s2", "A", "A", "right"),
            ("p2", "s7", "B", "A", "undecided"),
        ]
    )
    c = count_votes(t)
    assert c.conditions == ("A", "B") and c.participants == ("p1", "p2")
    assert c.clips == ("s2", "s7") and c.tensor.sum() == 4
    assert ballots(c.tensor.sum(axis=(0, 1))).tolist() == [2, 1]  # A: 1 + same pair, B: 1
    wins = c.wins().sum(axis=(0, 1))
    assert wins.tolist() == [[1, 1], [1, 0]]
    split = c.wins("split").sum(axis=(0, 1))
    assert split.tolist() == [[1, 1.5], [1.5, 0]]
    assert c.undecided_pairs().sum(axis=(0, 1))[0, 1] == 1


def test_explicit_condition_order_and_unknown():
    t = _table([("p1", "s2", "A", "B", "left")])
    assert count_votes(t, ["B", "A", "C"]).conditions == ("B", "A", "C")
    with pytest.raises(InputError, match="not in the list: B"):
        count_votes(t, ["A"])
    with pytest.raises(InputError, match="undecided"):
        count_votes(t).wins("ignore")


def test_ballots_axis_convention():
    tensor = np.zeros((2, 2, 3), int)
    tensor[0, 1, 0] = 3  # A left chosen over B
    tensor[0, 1, 1] = 2  # B right chosen over A
    assert ballots(tensor).tolist() == [3, 2]
