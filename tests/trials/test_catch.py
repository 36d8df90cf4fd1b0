"""Catch trials: spread over the schedule, on the clip before them, their answers balanced."""

from __future__ import annotations

import doctest
from collections import Counter

import pytest

from app.trials import catch as catch_module
from app.trials.design import ConditionPair, build_pairs
from app.trials.schedule import make_schedule

THESIS = ["none", "random", "speech_driven", "ground_truth"]


def test_docstring_examples() -> None:
    assert doctest.testmod(catch_module).failed == 0


def test_identical_catch_trials_show_one_condition_twice_and_expect_undecided() -> None:
    pairs = build_pairs(THESIS, "unordered_counterbalanced")
    trials = make_schedule(
        clips=["s2", "s7"],
        pairs=pairs,
        design="unordered_counterbalanced",
        seed=3,
        list_index=0,
        n_lists=4,
        catch_trials=3,
        practice_pair=ConditionPair("none", "ground_truth"),
    )
    assert len(trials) == 1 + 12 + 3
    assert trials[0].kind == "practice" and trials[0].expected is None
    catches = [t for t in trials if t.kind == "catch"]
    assert len(catches) == 3
    for catch in catches:
        assert catch.left == catch.right and catch.expected == "undecided"
        before = trials[catch.position - 1]
        assert before.kind == "trial" and before.clip == catch.clip
        assert catch.left in (before.left, before.right)
        assert catch.catch_passed("undecided") is True and catch.catch_passed("left") is False
    assert trials[1].catch_passed("left") is None


@pytest.mark.parametrize("n_catch", [1, 2, 3, 4, 5, 12])
def test_instructed_catch_trials_are_spread_and_balanced(n_catch: int) -> None:
    pairs = build_pairs(THESIS, "unordered_counterbalanced")
    for seed in range(20):
        trials = make_schedule(
            clips=["s2", "s7"],
            pairs=pairs,
            design="unordered_counterbalanced",
            seed=seed,
            list_index=1,
            n_lists=4,
            catch_trials=n_catch,
            catch_kind="instructed",
        )
        main_before = [
            sum(1 for u in trials[: t.position] if u.kind == "trial")
            for t in trials
            if t.kind == "catch"
        ]
        assert len(main_before) == n_catch
        for i, count in enumerate(main_before):  # catch i lies in segment i of the 12 trials
            assert 12 * i // n_catch < count <= 12 * (i + 1) // n_catch
        answers = Counter(t.expected for t in trials if t.kind == "catch")
        assert set(answers) <= {"left", "right"}
        assert abs(answers["left"] - answers["right"]) <= 1
        shown = {(t.clip, t.pair) for t in trials if t.kind == "trial"}
        assert all((t.clip, t.pair) in shown for t in trials if t.kind == "catch")
