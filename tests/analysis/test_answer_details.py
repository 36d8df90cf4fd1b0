"""The 5-level strengths and reason tags summarised (``app.analysis.answer_details``), on votes
whose answers are known."""

import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from app.analysis.answer_details import LEVELS, reason_summary, strength_summary
from tests.support.answer_votes import VOTES, answer_frame


def test_levels_are_counted_per_pair_from_its_first_condition():
    summary = strength_summary(answer_frame(), ["a", "b", "c"])
    assert summary["levels"] == list(LEVELS)
    ab, ac = summary["pairs"]
    assert (ab["a"], ab["b"], ab["counts"], ab["votes"]) == ("a", "b", [2, 1, 1, 1, 0], 5)
    assert ab["mean"] == (2 + 2 + 1 + 0 - 1) / 5
    assert (ac["a"], ac["b"], ac["counts"], ac["mean"]) == ("a", "c", [0, 0, 0, 0, 1], -2.0)
    assert summary["pooled"] == [2, 1, 1, 1, 1] and summary["votes"] == 6
    assert summary["mean"] == (2 + 2 + 1 + 0 - 1 - 2) / 6


def test_the_conditions_order_names_the_first_of_a_pair():
    ba = strength_summary(answer_frame(), ["b", "a", "c"])["pairs"][0]
    assert (ba["a"], ba["b"], ba["counts"]) == ("b", "a", [0, 1, 1, 1, 2])


def test_three_level_votes_have_no_strength_summary():
    frame = answer_frame().assign(strength=pd.array([pd.NA] * len(VOTES), dtype="Int64"))
    assert strength_summary(frame, ["a", "b", "c"]) is None
    assert strength_summary(answer_frame().drop(columns="strength"), ["a", "b"]) is None


def test_reason_tags_by_the_condition_chosen():
    summary = reason_summary(answer_frame(), ["a", "b", "c"])
    assert list(summary["tags"]) == ["lips", "eyes", "head"]  # by falling total, then name
    assert summary["tags"]["lips"] == {"total": 3, "a": 2, "b": 0, "c": 1, "undecided": 0}
    assert summary["tags"]["eyes"] == {"total": 2, "a": 1, "b": 0, "c": 0, "undecided": 1}
    assert summary["tags"]["head"] == {"total": 1, "a": 0, "b": 1, "c": 0, "undecided": 0}
    assert (summary["votes"], summary["of"]) == (5, 6)
    assert reason_summary(answer_frame().assign(reasons=""), ["a", "b", "c"]) is None


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["a", "b", "c"]),
            st.sampled_from(["a", "b", "c"]),
            st.sampled_from(["left", "right", "undecided"]),
            st.integers(0, 2),
            st.lists(st.sampled_from(["lips", "eyes", "head"]), max_size=3).map(";".join),
        ),
        min_size=1,
        max_size=30,
    )
)
def test_every_counted_vote_is_one_level_and_every_tag_one_tick(rows):
    frame = answer_frame(rows)
    summary = strength_summary(frame, ["a", "b", "c"])
    countable = sum(
        left != right and ((choice == "undecided") == (strength == 0))
        for left, right, choice, strength, _ in rows
    )
    assert (summary["votes"] if summary else 0) == countable
    reasons = reason_summary(frame, ["a", "b", "c"])
    ticks = sum(len(set(filter(None, r[4].split(";")))) for r in rows)
    assert (sum(t["total"] for t in reasons["tags"].values()) if reasons else 0) == ticks


def test_blank_reasons_are_no_tags_whatever_the_column_type():
    base = {"choice": ["left", "right"], "left": ["a", "b"], "right": ["b", "a"]}
    for reasons in (
        pd.Series(["", " "]),
        pd.Series(["", " "], dtype="category"),
        pd.Categorical(["", ""], categories=["", "smooth"]),  # a category no row uses
    ):
        assert reason_summary(pd.DataFrame({**base, "reasons": reasons}), ["a", "b"]) is None
    tagged = pd.DataFrame({**base, "reasons": pd.Categorical(["smooth", ""])})
    assert reason_summary(tagged, ["a", "b"])["tags"]["smooth"]["a"] == 1
