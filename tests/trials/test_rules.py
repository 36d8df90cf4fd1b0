"""Replay and vote rules, and the vote choices shared with the analysis package."""

from __future__ import annotations

import doctest

import pytest
from hypothesis import given
from hypothesis import strategies as st

from app.trials import rules
from app.trials.rules import (
    CHOICES,
    KEYS,
    REPLAY_KINDS,
    ReplayPolicy,
    VoteChoice,
    allowed_choices,
    answers,
    check_choice,
    may_play,
    may_vote,
    play_refusal,
    vote_refusal,
)


def test_docstring_examples() -> None:
    assert doctest.testmod(rules).failed == 0


def test_the_votes_schema_reads_its_choices_from_here() -> None:
    from app.analysis import votes

    assert votes.CHOICES is CHOICES
    assert CHOICES == ("left", "right", "undecided")


def test_vote_choice_values_are_the_choices_in_order() -> None:
    assert tuple(c.value for c in VoteChoice) == tuple(CHOICES)
    assert VoteChoice("left") == "left"


def test_unlimited_plays_need_one_start_before_a_vote() -> None:
    # Le et al. 2012, sec. 8.1: clips viewed "for unlimited times before made their decisions"
    policy = ReplayPolicy()
    assert policy.kind == "unlimited"
    assert all(may_play(policy, n) for n in range(100))
    assert not may_vote(policy, 0, False)
    assert may_vote(policy, 1, False) and may_vote(policy, 50, True)


def test_max_plays_caps_the_starts() -> None:
    policy = ReplayPolicy("max_plays", max_plays=2)
    assert [may_play(policy, n) for n in range(4)] == [True, True, False, False]
    assert [may_vote(policy, n, False) for n in range(4)] == [False, True, True, False]


def test_play_to_end_needs_a_finished_play() -> None:
    policy = ReplayPolicy("play_to_end")
    assert may_play(policy, 0) and may_play(policy, 10)
    assert not may_vote(policy, 1, False) and not may_vote(policy, 3, False)
    assert may_vote(policy, 1, True)
    assert not may_vote(policy, 0, True)


@given(st.sampled_from(REPLAY_KINDS), st.integers(1, 9), st.integers(0, 20), st.booleans())
def test_a_vote_never_comes_without_a_play(kind: str, cap: int, plays: int, finished: bool) -> None:
    policy = ReplayPolicy(kind, cap if kind == "max_plays" else None)
    if may_vote(policy, plays, finished):
        assert plays >= 1
    if kind == "max_plays":
        assert may_play(policy, plays) == (plays < cap)


@pytest.mark.parametrize(
    ("kind", "max_plays", "message"),
    [
        ("twice", None, "expected one of unlimited, max_plays, play_to_end, got 'twice'"),
        ("max_plays", None, "positive integer"),
        ("max_plays", 0, "positive integer"),
        ("max_plays", True, "positive integer"),
        ("unlimited", 3, "only applies to kind 'max_plays'"),
    ],
)
def test_bad_policies_are_refused(kind: str, max_plays: int | None, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ReplayPolicy(kind, max_plays)


def test_negative_plays_are_refused() -> None:
    with pytest.raises(ValueError):
        may_play(ReplayPolicy(), -1)
    with pytest.raises(ValueError):
        may_vote(ReplayPolicy(), -1, False)


def test_undecided_only_when_allowed() -> None:
    assert allowed_choices(undecided_allowed=True) == ("left", "right", "undecided")
    assert allowed_choices(undecided_allowed=False) == ("left", "right")
    assert check_choice("undecided", undecided_allowed=True) is VoteChoice.UNDECIDED
    with pytest.raises(ValueError, match="expected one of left, right, got 'undecided'"):
        check_choice("undecided", undecided_allowed=False)
    with pytest.raises(ValueError, match="got 'up'"):
        check_choice("up", undecided_allowed=True)


@given(st.sampled_from(REPLAY_KINDS), st.integers(1, 9), st.integers(0, 20), st.booleans())
def test_a_vote_is_refused_with_a_reason_exactly_when_the_rule_forbids_it(
    kind: str, cap: int, plays: int, finished: bool
) -> None:
    policy = ReplayPolicy(kind, cap if kind == "max_plays" else None)
    reason = vote_refusal(policy, plays, finished)
    assert (reason is None) == may_vote(policy, plays, finished)
    if reason is not None:
        field = reason.split(":")[0]
        assert field in ("plays", "watched_to_end") and "\n" not in reason


def test_refusals_name_the_rule() -> None:
    assert vote_refusal(ReplayPolicy(), 0, True) == "plays: the clip must be played before voting"
    assert vote_refusal(ReplayPolicy("max_plays", max_plays=2), 3, True) == (
        "plays: at most 2 plays are allowed"
    )
    assert play_refusal(ReplayPolicy("max_plays", max_plays=4)) == (
        "plays: at most 4 plays are allowed"
    )
    assert ReplayPolicy("play_to_end").needs_end and not ReplayPolicy().needs_end


@pytest.mark.parametrize("scale", [3, 5])
@pytest.mark.parametrize("undecided", [True, False])
def test_answer_buttons_cast_only_allowed_choices_with_distinct_keys(
    scale: int, undecided: bool
) -> None:
    buttons = answers(scale=scale, undecided_allowed=undecided, undecided_label="Same")
    assert {b.choice for b in buttons} == set(allowed_choices(undecided_allowed=undecided))
    assert len({b.key for b in buttons}) == len(buttons)
    assert buttons[0].choice == "left" and buttons[-1].choice == "right"
    if scale == 3:
        assert all(KEYS[b.key] == b.choice and b.strength is None for b in buttons)
    else:
        assert [b.strength for b in buttons if b.choice != "undecided"] == [2, 1, 1, 2]
    assert ("Same" in [b.label for b in buttons]) == undecided


@given(st.one_of(st.text(max_size=300), st.integers(), st.none(), st.lists(st.text())))
def test_any_submitted_value_is_a_choice_or_one_line_refusal(value: object) -> None:
    try:
        assert check_choice(value, undecided_allowed=True) in CHOICES
    except ValueError as exc:
        message = str(exc)
        assert message.startswith("expected one of left, right, undecided, got ")
        assert len(message) < 100


def test_the_instructed_side_is_that_of_a_left_or_right_check_without_its_own_instruction():
    read: list[str] = []

    def instruction(text: str):
        def get() -> str:
            read.append(text)
            return text

        return get

    assert rules.instructed_side("catch", "left", instruction("")) == "left"
    assert rules.instructed_side("catch", "right", instruction("")) == "right"
    # On screen in the clip: nothing in words. An identical pair expects "undecided".
    assert rules.instructed_side("catch", "left", instruction("left")) is None
    assert rules.instructed_side("catch", "undecided", instruction("")) is None
    assert rules.instructed_side("trial", None, instruction("")) is None
    # The instruction is read only for a check that could ask for a side.
    assert read == ["", "", "left"]
