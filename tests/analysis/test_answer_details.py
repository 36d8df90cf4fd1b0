"""The 5-level strengths and reason tags summarised (``app.analysis.answer_details``) and their
report section (``app.analysis.answer_document``), on votes whose answers are known."""

import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from app.analysis import analyze
from app.analysis.answer_details import LEVELS, reason_summary, strength_summary
from app.analysis.answer_document import answer_detail_blocks
from app.analysis.document import Heading, Plot, Table, build_document

# (left, right, choice, strength, reasons): a vs b and b vs a, both presentation orders.
VOTES = [
    ("a", "b", "left", 2, "lips;eyes"),  # clearly a
    ("b", "a", "right", 2, "lips"),  # clearly a, shown on the right
    ("a", "b", "left", 1, ""),  # slightly a
    ("b", "a", "left", 1, "head"),  # slightly b
    ("a", "b", "undecided", 0, "eyes"),  # cannot decide
    ("a", "c", "right", 2, "lips"),  # clearly c
]


def _frame(rows=VOTES, participant="p1"):
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


def test_levels_are_counted_per_pair_from_its_first_condition():
    summary = strength_summary(_frame(), ["a", "b", "c"])
    assert summary["levels"] == list(LEVELS)
    ab, ac = summary["pairs"]
    assert (ab["a"], ab["b"], ab["counts"], ab["votes"]) == ("a", "b", [2, 1, 1, 1, 0], 5)
    assert ab["mean"] == (2 + 2 + 1 + 0 - 1) / 5
    assert (ac["a"], ac["b"], ac["counts"], ac["mean"]) == ("a", "c", [0, 0, 0, 0, 1], -2.0)
    assert summary["pooled"] == [2, 1, 1, 1, 1] and summary["votes"] == 6
    assert summary["mean"] == (2 + 2 + 1 + 0 - 1 - 2) / 6


def test_the_conditions_order_names_the_first_of_a_pair():
    ba = strength_summary(_frame(), ["b", "a", "c"])["pairs"][0]
    assert (ba["a"], ba["b"], ba["counts"]) == ("b", "a", [0, 1, 1, 1, 2])


def test_three_level_votes_have_no_strength_summary():
    frame = _frame().assign(strength=pd.array([pd.NA] * len(VOTES), dtype="Int64"))
    assert strength_summary(frame, ["a", "b", "c"]) is None
    assert strength_summary(_frame().drop(columns="strength"), ["a", "b"]) is None


def test_reason_tags_by_the_condition_chosen():
    summary = reason_summary(_frame(), ["a", "b", "c"])
    assert list(summary["tags"]) == ["lips", "eyes", "head"]  # by falling total, then name
    assert summary["tags"]["lips"] == {"total": 3, "a": 2, "b": 0, "c": 1, "undecided": 0}
    assert summary["tags"]["eyes"] == {"total": 2, "a": 1, "b": 0, "c": 0, "undecided": 1}
    assert summary["tags"]["head"] == {"total": 1, "a": 0, "b": 1, "c": 0, "undecided": 0}
    assert (summary["votes"], summary["of"]) == (5, 6)
    assert reason_summary(_frame().assign(reasons=""), ["a", "b", "c"]) is None


def test_the_report_has_the_tables_and_figures_only_when_asked():
    frame = pd.concat([_frame(participant="p1"), _frame(participant="p2")])
    results = analyze(frame, conditions=["a", "b", "c"], bootstrap=20, mixed_model=False)
    assert results["strengths"]["pooled"] == [4, 2, 2, 2, 2]
    assert results["reasons"]["tags"]["lips"]["total"] == 6
    blocks = answer_detail_blocks(results)
    assert isinstance(blocks[0], Heading) and blocks[0].text == "Answer details"
    tables = [b for b in blocks if isinstance(b, Table)]
    assert tables[0].rows[0] == ["a vs b", "4", "2", "2", "2", "0", "10", "0.80"]
    assert tables[0].rows[-1][0] == "all pairs" and tables[1].rows[0][:2] == ["lips", "6"]
    assert sum(isinstance(b, Plot) for b in blocks) == 2
    headings = [b.text for b in build_document(results) if isinstance(b, Heading)]
    assert "Answer details" in headings
    plain = analyze(
        frame.drop(columns=["strength", "reasons"]),
        conditions=["a", "b", "c"],
        bootstrap=20,
        mixed_model=False,
    )
    assert answer_detail_blocks(plain) == []


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
    frame = _frame(rows)
    summary = strength_summary(frame, ["a", "b", "c"])
    countable = sum(
        left != right and ((choice == "undecided") == (strength == 0))
        for left, right, choice, strength, _ in rows
    )
    assert (summary["votes"] if summary else 0) == countable
    reasons = reason_summary(frame, ["a", "b", "c"])
    ticks = sum(len(set(filter(None, r[4].split(";")))) for r in rows)
    assert (sum(t["total"] for t in reasons["tags"].values()) if reasons else 0) == ticks
