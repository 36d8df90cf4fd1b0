"""Balanced assignment of arriving participants to counterbalancing lists.

Each list (:func:`app.trials.schedule.n_lists_for`) is one side order and one block order of the
design; participants are spread over the lists so that every pair is seen in both orders by
equally many people (thesis sec. 5.3 split its fourteen surveys six/eight over the two segment
orders by hand; here the split is kept within one automatically).

How the web layer must use this
-------------------------------
The counts come from an *assignment table*: one row per (study, list) holding the number of
participants currently holding or having completed that list. In ONE transaction the web layer
reads the study's rows, calls :func:`choose_list`, raises the chosen row's count and inserts
the participant. Two arrivals must not both act on the same reading: either lock the rows
(``SELECT ... FOR UPDATE``) or make the increment conditional on the count read
(``UPDATE ... WHERE n_assigned = :seen``) and, when it touches no row, read again and retry a
bounded number of times. A participant who drops out (abandons or times out) gives the slot
back by decrementing the row, again in one transaction. Never derive counts by counting
participant rows: the count then depends on which rows a query happens to include (psiTurk
issue #244: participants of an earlier version with a different number of conditions kept
steering assignment; #295: test-mode participants were counted with live ones), on how
drop-outs are guessed, and concurrent arrivals read the same count and pile onto one list. A
table of counts says exactly which participants hold which list.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np


def choose_list(counts: Mapping[int, int], rng: np.random.Generator) -> int:
    """The list for the next participant: the least-filled one, ties broken at random.

    Parameters
    ----------
    counts:
        List index -> participants holding or having completed that list (every list of the
        study must be present, an empty list with count 0).
    rng:
        A seeded ``numpy.random.Generator``, so a replayed sequence of arrivals is reproducible.

    Returns
    -------
    The chosen list index. Always one of the minimum-count lists, so if the counts differ by at
    most one before the call they still do after incrementing the chosen list.

    >>> choose_list({0: 3, 1: 2, 2: 3}, np.random.default_rng(0))
    1
    """
    if not counts:
        raise ValueError("no lists to choose from")
    if any(c < 0 for c in counts.values()):
        raise ValueError(f"counts must be non-negative, got {dict(counts)}")
    fewest = min(counts.values())
    candidates = sorted(index for index, count in counts.items() if count == fewest)
    return candidates[int(rng.integers(len(candidates)))]


def initial_counts(n_lists: int) -> dict[int, int]:
    """Zero counts for lists ``0 .. n_lists-1``: the assignment table of a new study.

    >>> initial_counts(3)
    {0: 0, 1: 0, 2: 0}
    """
    if n_lists < 1:
        raise ValueError(f"need at least one list, got {n_lists}")
    return dict.fromkeys(range(n_lists), 0)
