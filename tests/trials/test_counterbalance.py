"""Counterbalancing: Williams squares balance positions and successions, orientations sides."""

from __future__ import annotations

import doctest
from collections import Counter
from itertools import pairwise

from hypothesis import given
from hypothesis import strategies as st

from app.trials import counterbalance
from app.trials.counterbalance import balanced_orientation, williams_square
from app.trials.design import ConditionPair


def test_docstring_examples() -> None:
    assert doctest.testmod(counterbalance).failed == 0


@given(st.integers(1, 12))
def test_williams_square_is_a_balanced_latin_square(n: int) -> None:
    rows = williams_square(n)
    assert len(rows) == (2 * n if n % 2 and n > 1 else n)
    for row in rows:
        assert sorted(row) == list(range(n))
    for position in range(n):
        column = Counter(row[position] for row in rows)
        assert set(column.values()) == {len(rows) // n}
    adjacent = Counter(pair for row in rows for pair in pairwise(row))
    if n > 1:
        assert len(adjacent) == n * (n - 1)
        assert set(adjacent.values()) == {len(rows) // n}


@given(
    st.sets(
        st.tuples(st.integers(0, 7), st.integers(0, 7)).filter(lambda e: e[0] < e[1]), min_size=1
    )
)
def test_balanced_orientation_keeps_edges_and_balances_every_vertex(
    edges: set[tuple[int, int]],
) -> None:
    comparisons = [ConditionPair(str(a), str(b)) for a, b in sorted(edges)]
    oriented = balanced_orientation(comparisons)
    assert [p.conditions for p in oriented] == [p.conditions for p in comparisons]
    left = Counter(p.left for p in oriented)
    right = Counter(p.right for p in oriented)
    assert all(abs(left[v] - right[v]) <= 1 for v in set(left) | set(right))


def test_balanced_orientation_of_a_triangle_is_a_cycle() -> None:
    oriented = balanced_orientation(
        [ConditionPair("a", "b"), ConditionPair("a", "c"), ConditionPair("b", "c")]
    )
    assert Counter(p.left for p in oriented) == Counter({"a": 1, "b": 1, "c": 1})
