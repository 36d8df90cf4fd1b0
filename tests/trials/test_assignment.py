"""Balanced list assignment: least-filled list, seeded ties, balance despite drop-outs."""

from __future__ import annotations

import doctest
from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.trials import assignment
from app.trials.assignment import choose_list, initial_counts


def test_docstring_examples() -> None:
    assert doctest.testmod(assignment).failed == 0


def test_least_filled_list_wins() -> None:
    rng = np.random.default_rng(0)
    assert choose_list({0: 5, 1: 4, 2: 7, 3: 4}, rng) in (1, 3)
    assert choose_list({0: 1, 1: 1, 2: 0}, rng) == 2
    assert choose_list({7: 2}, rng) == 7


def test_ties_are_broken_reproducibly_and_evenly() -> None:
    counts = initial_counts(4)
    first = [choose_list(counts, np.random.default_rng(seed)) for seed in range(400)]
    again = [choose_list(counts, np.random.default_rng(seed)) for seed in range(400)]
    assert first == again
    spread = Counter(first)
    assert set(spread) == {0, 1, 2, 3}
    assert min(spread.values()) > 60  # 100 expected per list


def test_ties_among_filled_lists_are_random_too() -> None:
    counts = {0: 3, 1: 5, 2: 3, 3: 3}
    chosen = Counter(choose_list(counts, np.random.default_rng(seed)) for seed in range(300))
    assert set(chosen) == {0, 2, 3}


def test_first_arrivals_fill_every_list_once_before_any_twice() -> None:
    rng = np.random.default_rng(3)
    counts = initial_counts(6)
    chosen = []
    for _ in range(6):
        chosen.append(choose_list(counts, rng))
        counts[chosen[-1]] += 1
    assert sorted(chosen) == list(range(6))
    assert chosen != list(range(6))  # ties broken at random, not by index


def test_bad_counts_are_refused() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="no lists"):
        choose_list({}, rng)
    with pytest.raises(ValueError, match="non-negative"):
        choose_list({0: -1, 1: 0}, rng)
    with pytest.raises(ValueError, match="at least one list"):
        initial_counts(0)


@settings(max_examples=200, deadline=None)
@given(
    n_lists=st.integers(1, 12),
    target=st.integers(1, 80),
    seed=st.integers(0, 2**32),
    drop_rate=st.floats(0.0, 0.6),
)
def test_counts_stay_within_one_over_arrivals_and_drop_outs(
    n_lists: int, target: int, seed: int, drop_rate: float
) -> None:
    """Simulate a study: participants arrive while fewer than ``target`` slots are held; held
    participants finish or drop out in random order, a drop-out giving its slot back."""
    rng = np.random.default_rng(seed)
    events = np.random.default_rng(seed + 1)
    counts = initial_counts(n_lists)  # the assignment table: holding + completed per list
    active: list[int] = []  # lists of participants still in the study
    completed = Counter[int]()
    drops = 0
    while sum(completed.values()) < target:
        if sum(counts.values()) < target and (not active or events.random() < 0.5):
            chosen = choose_list(counts, rng)
            assert counts[chosen] == min(counts.values())
            counts[chosen] += 1
            active.append(chosen)
            if drops == 0:  # without drop-outs the balance holds after every arrival
                assert max(counts.values()) - min(counts.values()) <= 1
        else:
            index = int(events.integers(len(active)))
            gone = active.pop(index)
            if events.random() < drop_rate:
                counts[gone] -= 1
                drops += 1
            else:
                completed[gone] += 1
    assert not active and dict(completed) == {k: v for k, v in counts.items() if v}
    assert max(counts.values()) - min(counts.values()) <= 1
    assert sum(counts.values()) == target
