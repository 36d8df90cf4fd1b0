"""Counterbalancing: balanced orders of treatments and balanced sides of comparisons.

Orders
    :func:`williams_square` gives the rows of a balanced Latin square (Williams 1949): over its
    rows every treatment comes at every position equally often and follows every other
    treatment equally often. The schedules order clip blocks by a row chosen by the
    participant's list (thesis sec. 5.3 ran six surveys with S7 first and eight with S2 first),
    the rating designs the conditions inside a block (:mod:`app.trials.rating`).

Sides
    :func:`balanced_orientation` orients the comparisons one participant sees so that every
    condition is on the left as often as on the right, within one (an Euler circuit of the
    comparison graph), the counterbalancing Le, Ma & Deng 2012 (sec. 8.1) ask for: "To counter
    balance the order of the visual stimuli ...".
"""

from __future__ import annotations

from collections.abc import Sequence

from app.trials.design import ConditionPair


def williams_square(n: int) -> list[list[int]]:
    """Rows of a balanced Latin square (Williams 1949) for ``n`` treatments.

    Every treatment appears once in every position per ``n`` rows, and every ordered pair of
    distinct treatments is adjacent equally often: once for even ``n`` (``n`` rows), twice for
    odd ``n`` (``2n`` rows: the cyclic square and its mirror). ``n == 1`` gives ``[[0]]``.

    >>> williams_square(4)
    [[0, 1, 3, 2], [1, 2, 0, 3], [2, 3, 1, 0], [3, 0, 2, 1]]
    """
    if n < 1:
        raise ValueError(f"need at least one treatment, got {n}")
    if n == 1:
        return [[0]]
    first = [0]
    low, high = 1, n - 1
    while len(first) < n:
        first.append(low)
        low += 1
        if len(first) < n:
            first.append(high)
            high -= 1
    rows = [[(t + r) % n for t in first] for r in range(n)]
    if n % 2:
        rows += [row[::-1] for row in rows]
    return rows


def balanced_orientation(comparisons: Sequence[ConditionPair]) -> list[ConditionPair]:
    """Orient comparisons so each condition is on the left as often as on the right, within one.

    Classic construction: join every odd-degree condition to a virtual vertex, so all degrees
    are even, walk an Euler circuit of each component (Hierholzer) and orient every edge the
    way the walk crosses it; a closed walk leaves each vertex as often as it enters it, and
    dropping the virtual edges changes each count by at most one. Deterministic: the result
    depends only on the order of ``comparisons``.

    >>> oriented = balanced_orientation([ConditionPair("a", "b"), ConditionPair("a", "c"),
    ...                                  ConditionPair("b", "c")])
    >>> [(p.left, p.right) for p in oriented]
    [('a', 'b'), ('c', 'a'), ('b', 'c')]
    """
    if any(p.is_same for p in comparisons):
        raise ValueError("same-condition pairs have no side to balance")
    virtual = object()
    edges: list[tuple[object, object]] = [(p.left, p.right) for p in comparisons]
    degree: dict[object, int] = {}
    for a, b in edges:
        degree[a] = degree.get(a, 0) + 1
        degree[b] = degree.get(b, 0) + 1
    edges += [(v, virtual) for v, d in degree.items() if d % 2]
    adjacency: dict[object, list[tuple[int, object]]] = {}
    for index, (a, b) in enumerate(edges):
        adjacency.setdefault(a, []).append((index, b))
        adjacency.setdefault(b, []).append((index, a))
    used = [False] * len(edges)
    cursor = dict.fromkeys(adjacency, 0)
    oriented: list[tuple[object, object]] = list(edges)
    for start in adjacency:
        stack = [start]
        while stack:
            vertex = stack[-1]
            links = adjacency[vertex]
            while cursor[vertex] < len(links) and used[links[cursor[vertex]][0]]:
                cursor[vertex] += 1
            if cursor[vertex] == len(links):
                stack.pop()
                continue
            index, other = links[cursor[vertex]]
            used[index] = True
            oriented[index] = (vertex, other)
            stack.append(other)
    return [ConditionPair(str(a), str(b)) for a, b in oriented[: len(comparisons)]]
