import numpy as np
import pytest

from app.analysis.clip_statistics import clip_statistics

OPTIONS = {"undecided": "exclude", "bootstrap": 0, "seed": 0, "confidence": 0.95, "anchor": None}


def _tensor(votes, participants, conditions):
    """A (P, n, n, 3) tensor from (participant, left, right, outcome 0 left / 1 right / 2
    undecided) votes."""
    t = np.zeros((participants, conditions, conditions, 3))
    for vote in votes:
        t[vote] += 1
    return t


def test_one_clip_by_hand():
    # p0 prefers 0 to 1 on both sides; p1 once each way and once undecided; p2 saw nothing
    votes = [(0, 0, 1, 0), (0, 1, 0, 1), (1, 0, 1, 0), (1, 1, 0, 0), (1, 0, 1, 2)]
    s = clip_statistics(_tensor(votes, 3, 2), ["a", "b"], **OPTIONS)
    assert s["votes"] == 5 and s["participants"] == 2 and s["undecided"] == 1
    assert s["ballots"] == {"a": 3, "b": 1} and s["same_condition_votes"] == 0
    assert s["confusion"]["left"] == [[0, 2], [1, 0]]
    assert s["scores"]["a"]["mean"] == pytest.approx(1.5)
    (sign,) = s["sign_tests"]
    assert (sign["a"], sign["b"], sign["wins"], sign["losses"], sign["undecided"]) == (
        "a",
        "b",
        3,
        1,
        1,
    )
    assert sign["p_holm"] == sign["p"] == pytest.approx(0.625)
    assert s["agreement"]["undecided"] == "exclude" and s["agreement"]["undecided_votes"] == 1
    assert [row["a"] for row in s["paired_t"]] == ["a"] and s["paired_t"][0]["n"] == 2


def test_a_condition_never_compared_has_no_scale_and_cannot_anchor_it():
    votes = [(0, 0, 1, 0), (0, 1, 0, 1), (1, 0, 1, 1), (1, 1, 0, 0)]
    t = _tensor(votes, 2, 3)
    s = clip_statistics(t, ["a", "b", "c"], **OPTIONS)
    assert s["scale_note"] == "never compared: c"
    assert s["scale"][2] == {"condition": "c", "score": None, "ci_low": None, "ci_high": None}
    assert [row["a"] + row["b"] for row in s["sign_tests"]] == ["ab"]
    anchored = clip_statistics(t, ["a", "b", "c"], **{**OPTIONS, "anchor": 2})
    assert anchored["scale_note"] == "anchor 'c' was never compared"


def test_pairs_that_do_not_link_the_conditions_have_no_common_scale():
    votes = [(0, 0, 1, 0), (0, 2, 3, 0)]
    s = clip_statistics(_tensor(votes, 1, 4), ["a", "b", "c", "d"], **OPTIONS)
    assert s["scale_note"] == "the compared pairs do not link all conditions; no common scale"
    assert all(row["score"] is None for row in s["scale"])
