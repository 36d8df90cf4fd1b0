"""Rating designs: each clip of each condition rated on its own, in a balanced order.

``rating`` is the single-stimulus absolute category rating of ITU-T P.910 (2008), sec. 6.1
(ACR): one face is shown, then rated on the five labelled levels Excellent, Good, Fair, Poor,
Bad, scored 5 to 1 (sec. 6.1, Table 1), or on a continuous 0-100 slider with the same words
at its ends and middle (the 0-100 scale of ITU-R BS.1534-3, sec. 5.1, used as one slider).
Every participant rates every clip of every condition once (the full factorial design of
P.910 sec. 6: "each test condition" with every source sequence).

Presentation order is balanced two ways. Conditions: a participant's trials fall into one
block per clip slot, and inside every block the conditions follow one row of a balanced
Latin square (Williams 1949, :func:`app.trials.counterbalance.williams_square`) chosen by the
participant's list, so over one cycle of lists every condition is at every place in the
block equally often and follows every other condition equally often. Clips: shuffled per
participant from the stored seed and spread over the blocks so that the condition at place
``j`` of block ``b`` shows clip ``(b + j) mod K``: every clip once per condition.

Attention checks (``catch.kind = "instructed"``): a repeat of the trial before with the
instruction to rate it at the bottom of the scale ("Bad"); :func:`catch_passed` says whether
a score obeys it.

``parallel`` is the MUSHRA-like test of ITU-R BS.1534-3 adapted to video: one trial per clip,
every condition of the clip on its own 0-100 slider side by side, the ``reference`` condition
once among them unlabelled (the hidden reference, sec. 5.1) and once labelled, playable apart
(:func:`parallel_schedule`, :func:`parallel_order`). Its attention check is the hidden
reference itself: the analysis's post-screening (sec. 4.1.2) leaves out a participant who
rates it too low too often (:func:`app.analysis.rating_results.reference_screening`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Final

import numpy as np

from app.trials.catch import catch_slots
from app.trials.counterbalance import williams_square
from app.trials.trial import ScheduledTrial

RATING_SCALES: Final = ("acr5", "slider")
"""Rating scales: ``acr5`` (ITU-T P.910 ACR, five labelled levels scored 5..1) or
``slider`` (0-100)."""
DEFAULT_RATING_SCALE: Final = "acr5"

ACR_LEVELS: Final[tuple[tuple[int, str], ...]] = (
    (5, "Excellent"),
    (4, "Good"),
    (3, "Fair"),
    (2, "Poor"),
    (1, "Bad"),
)
"""The ACR levels of ITU-T P.910 sec. 6.1, Table 1: score and label, best first."""

SCALE_RANGE: Final[dict[str, tuple[int, int]]] = {"acr5": (1, 5), "slider": (0, 100)}
"""Lowest and highest score of each scale."""

#: How far above the bottom of the slider an instructed check may land and still pass: a
#: finger on a phone rarely stops on exactly 0 (a tenth of the scale; ACR takes only "Bad").
SLIDER_CATCH_TOLERANCE: Final = 10

#: The ``expected`` answer stored with a rating attention check: the bottom of the scale.
CATCH_EXPECTED: Final = "bad"


def rating_lists(n_conditions: int) -> int:
    """Lists in one counterbalancing cycle: the rows of the Williams square of the conditions
    (``n`` for even ``n``, ``2n`` for odd ``n``).

    >>> rating_lists(4), rating_lists(3)
    (4, 6)
    """
    return len(williams_square(n_conditions))


def check_score(scale: str, score: object) -> int:
    """``score`` as an integer score of ``scale``, or ``ValueError`` saying what is expected.

    >>> check_score("acr5", 4), check_score("slider", 100.0)
    (4, 100)
    """
    low, high = SCALE_RANGE[scale]
    if isinstance(score, float) and score.is_integer():
        score = int(score)
    if isinstance(score, bool) or not isinstance(score, int) or not low <= score <= high:
        raise ValueError(f"expected a whole number from {low} to {high}")
    return score


def catch_ceiling(scale: str) -> int:
    """The highest score that obeys an instructed check (rate it at the bottom of the scale).

    >>> catch_ceiling("acr5"), catch_ceiling("slider")
    (1, 10)
    """
    return SCALE_RANGE[scale][0] + (SLIDER_CATCH_TOLERANCE if scale == "slider" else 0)


def catch_passed(scale: str, score: int) -> bool:
    """Whether ``score`` obeys an instructed check (:func:`catch_ceiling`).

    >>> catch_passed("acr5", 1), catch_passed("acr5", 2), catch_passed("slider", 8)
    (True, False, True)
    """
    return score <= catch_ceiling(scale)


def rating_schedule(
    *,
    clips: Sequence[str],
    conditions: Sequence[str],
    seed: int,
    list_index: int,
    n_lists: int,
    catch_trials: int = 0,
) -> list[ScheduledTrial]:
    """One participant's rating trials (``left == right ==`` the rated condition).

    Parameters
    ----------
    clips, conditions:
        Distinct names, in the study's order.
    seed:
        The participant's stored seed: shuffles the clips and places the checks.
    list_index, n_lists:
        The participant's list; ``n_lists`` a multiple of :func:`rating_lists`.
    catch_trials:
        Instructed checks (expected :data:`CATCH_EXPECTED`), one per equal stretch of the
        schedule, each repeating the trial before it.

    >>> s = rating_schedule(clips=["s2", "s7"], conditions=["a", "b"], seed=1,
    ...                     list_index=1, n_lists=2)
    >>> [(t.clip, t.left) for t in s] == [("s2", "b"), ("s7", "a"), ("s7", "b"), ("s2", "a")]
    True
    """
    clips, conditions = list(clips), list(conditions)
    if not clips or len(set(clips)) != len(clips):
        raise ValueError("clips must be a non-empty list of distinct names")
    if not conditions or len(set(conditions)) != len(conditions):
        raise ValueError("conditions must be a non-empty list of distinct names")
    cycle = rating_lists(len(conditions))
    if n_lists < 1 or n_lists % cycle:
        raise ValueError(f"n_lists must be a positive multiple of {cycle}, got {n_lists}")
    if not 0 <= list_index < n_lists:
        raise ValueError(f"list_index must be in 0..{n_lists - 1}, got {list_index}")
    rng = np.random.default_rng(seed)
    row = williams_square(len(conditions))[list_index % cycle]
    order = [clips[i] for i in rng.permutation(len(clips))]
    k = len(clips)
    main = [
        (order[(block + place) % k], conditions[c])
        for block in range(k)
        for place, c in enumerate(row)
    ]
    slots = catch_slots(len(main), catch_trials, rng)
    sequence: list[ScheduledTrial] = []
    pending = 0
    for index, (clip, condition) in enumerate(main):
        sequence.append(ScheduledTrial(0, clip, condition, condition))
        while pending < len(slots) and slots[pending] == index + 1:
            sequence.append(ScheduledTrial(0, clip, condition, condition, "catch", CATCH_EXPECTED))
            pending += 1
    return [replace(t, position=position) for position, t in enumerate(sequence)]


def parallel_lists(n_clips: int) -> int:
    """Lists of the ``parallel`` design: the rows of the Williams square of the clips.

    >>> parallel_lists(2), parallel_lists(3)
    (2, 6)
    """
    return len(williams_square(n_clips))


def parallel_schedule(
    *, clips: Sequence[str], reference: str, list_index: int, n_lists: int
) -> list[ScheduledTrial]:
    """One participant's ``parallel`` trials: one per clip, in the order of the list's row of
    the Williams square of the clips; each trial's condition is the labelled ``reference``
    (its items come from :func:`parallel_order`).

    >>> [t.clip for t in parallel_schedule(clips=["s2", "s7", "s9"], reference="gt",
    ...                                    list_index=1, n_lists=6)]
    ['s7', 's9', 's2']
    """
    clips = list(clips)
    if not clips or len(set(clips)) != len(clips):
        raise ValueError("clips must be a non-empty list of distinct names")
    cycle = parallel_lists(len(clips))
    if n_lists < 1 or n_lists % cycle:
        raise ValueError(f"n_lists must be a positive multiple of {cycle}, got {n_lists}")
    if not 0 <= list_index < n_lists:
        raise ValueError(f"list_index must be in 0..{n_lists - 1}, got {list_index}")
    row = williams_square(len(clips))[list_index % cycle]
    return [
        ScheduledTrial(position, clips[c], reference, reference) for position, c in enumerate(row)
    ]


def parallel_order(conditions: Sequence[str], *, seed: int, position: int) -> list[str]:
    """The conditions of a ``parallel`` trial in the order its items are shown, the hidden
    reference among them: shuffled per trial from the participant's seed and the trial's
    position, so a reload shows the same order.

    >>> parallel_order(["a", "b", "gt"], seed=7, position=0) == parallel_order(
    ...     ["a", "b", "gt"], seed=7, position=0)
    True
    """
    rng = np.random.default_rng([seed, position])
    return [conditions[i] for i in rng.permutation(len(conditions))]
