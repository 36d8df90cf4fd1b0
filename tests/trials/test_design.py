"""Pair designs: counts and contents with known answers (thesis TABLE 3; Le et al. 2012)."""

from __future__ import annotations

import doctest
import math
from itertools import permutations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from app.trials import design
from app.trials.design import PAIR_DESIGNS, ConditionPair, build_pairs, stimulus_pairs

THESIS = ["none", "random", "speech_driven", "ground_truth"]
names = st.lists(st.text("abcdefgh", min_size=1, max_size=3), min_size=2, max_size=8, unique=True)


def test_docstring_examples() -> None:
    assert doctest.testmod(design).failed == 0


def test_thesis_experiment_1_has_16_pairs_per_segment_like_table_3() -> None:
    pairs = build_pairs(THESIS, "all_ordered")
    assert len(pairs) == 16
    # TABLE 3 shows both RANDOM/SPEECH_DRIVEN and SPEECH_DRIVEN/RANDOM and SPEECH_DRIVEN twice
    assert ConditionPair("random", "speech_driven") in pairs
    assert ConditionPair("speech_driven", "random") in pairs
    assert ConditionPair("speech_driven", "speech_driven") in pairs
    assert sum(p.is_same for p in pairs) == 4
    assert len(set(pairs)) == 16


def test_reference_design_matches_the_2012_study_counts() -> None:
    # head motion study: "our approach" against four other approaches (sec. 8.1.1)
    conditions = ["ours", "levine", "chuang", "busso", "captured"]
    pairs = build_pairs(conditions, "reference", reference="ours")
    assert len(pairs) == 8
    assert all("ours" in (p.left, p.right) and not p.is_same for p in pairs)
    assert {p.conditions for p in pairs} == {frozenset({"ours", c}) for c in conditions[1:]}
    assert sum(p.left == "ours" for p in pairs) == 4


def test_unordered_design_lists_each_comparison_once_in_condition_order() -> None:
    pairs = build_pairs(["a", "b", "c"], "unordered_counterbalanced")
    assert pairs == [ConditionPair("a", "b"), ConditionPair("a", "c"), ConditionPair("b", "c")]


@given(names)
def test_pair_counts_per_design(conditions: list[str]) -> None:
    n = len(conditions)
    assert len(build_pairs(conditions, "all_ordered")) == n * n
    assert len(build_pairs(conditions, "reference", reference=conditions[-1])) == 2 * (n - 1)
    assert len(build_pairs(conditions, "unordered_counterbalanced")) == math.comb(n, 2)


@given(names)
def test_all_ordered_is_every_ordered_pair_with_repetition(conditions: list[str]) -> None:
    expected = set(permutations(conditions, 2)) | {(c, c) for c in conditions}
    assert {(p.left, p.right) for p in build_pairs(conditions, "all_ordered")} == expected


@given(names)
def test_stimulus_pairs_cover_both_orders_of_every_comparison(conditions: list[str]) -> None:
    for name in PAIR_DESIGNS:
        reference = conditions[0] if name == "reference" else None
        shown = stimulus_pairs(build_pairs(conditions, name, reference=reference), name)
        assert len(shown) == len(set(shown))
        assert {p.flipped() for p in shown} == set(shown)


def test_pair_is_frozen_and_flips() -> None:
    pair = ConditionPair("a", "b")
    with pytest.raises(AttributeError):
        pair.left = "c"  # type: ignore[misc]
    assert pair.flipped() == ConditionPair("b", "a") and pair.flipped().flipped() == pair
    assert pair.conditions == ConditionPair("b", "a").conditions


@pytest.mark.parametrize(
    ("conditions", "name", "reference", "message"),
    [
        (["a"], "all_ordered", None, "at least two conditions"),
        (["a", "a", "b"], "all_ordered", None, "repeated: a"),
        (["a", "b"], "foo", None, "expected one of all_ordered, reference"),
        (["a", "b"], "reference", None, "needs a reference"),
        (["a", "b"], "reference", "c", "'c' is not one of the conditions"),
        (["a", "b"], "all_ordered", "a", "only applies to designs 'reference'"),
    ],
)
def test_bad_designs_are_refused(
    conditions: list[str], name: str, reference: str | None, message: str
) -> None:
    with pytest.raises(ValueError, match=message):
        build_pairs(conditions, name, reference=reference)
