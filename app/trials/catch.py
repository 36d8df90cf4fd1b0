"""Catch trials: where they go among a participant's trials and what they show.

A few extra trials whose right answer is known tell an attentive participant from one who is
not. :func:`catch_slots` spreads them evenly through the schedule, never first;
:func:`catch_stimuli` puts each on the clip of the trial before it and gives the answer that
``ScheduledTrial.expected`` records (:mod:`app.trials.trial`). The ``identical`` kind is the
thesis' same-condition pair (TABLE 3) answered with the undecided option of Le, Ma & Deng 2012
(sec. 8.1). The pair designs place them in :func:`app.trials.schedule.make_schedule`, the
rating designs in :func:`app.trials.rating.rating_schedule`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Final

import numpy as np

from app.trials.design import ConditionPair

CATCH_KINDS: Final = ("identical", "instructed", "onscreen")
"""Kinds of catch trial.

``identical``
    The same condition on both sides of a clip (like the thesis' same-condition pairs, TABLE 3);
    the expected answer is ``"undecided"``, so it needs the undecided option (Le et al. 2012,
    sec. 8.1: "allowed to leave undecided choices if they cannot decide").
``instructed``
    An ordinary pair whose page tells the participant which side to pick ("for this pair,
    please choose left"); the expected answer is ``"left"`` or ``"right"``, balanced.
``onscreen``
    As ``instructed``, but the instruction ("press Left") is drawn into the clip by the
    renderer, so only a participant who watches the clip can pass; always the design's first
    displayed pair of the clip, so two extra clips per clip are rendered.
"""


def catch_slots(n_main: int, n_catch: int, rng: np.random.Generator) -> list[int]:
    """After how many main trials each catch trial comes: one per equal segment, never first.

    >>> catch_slots(12, 3, np.random.default_rng(0))
    [4, 7, 11]
    """
    if n_catch == 0:
        return []
    if n_catch > n_main:
        raise ValueError(f"{n_catch} catch trials do not fit among {n_main} trials")
    edges = [math.floor(i * n_main / n_catch) for i in range(n_catch + 1)]
    return [int(rng.integers(lo, hi)) + 1 for lo, hi in zip(edges[:-1], edges[1:], strict=True)]


def catch_stimuli(
    main: Sequence[tuple[str, ConditionPair]],
    slots: Sequence[int],
    kind: str,
    rng: np.random.Generator,
    onscreen: ConditionPair | None = None,
) -> list[tuple[str, ConditionPair, str]]:
    """Stimuli and expected answers of the catch trials, each on the clip of the trial before.

    ``identical`` shows one of the two conditions of the preceding trial on both sides;
    ``instructed`` repeats a random pair of the same clip, half of them to be answered ``left``;
    ``onscreen`` shows the pair ``onscreen``, half of them answered ``left``.
    """
    if not slots:
        return []
    n_catch = len(slots)
    answers = (["left", "right"] * (n_catch // 2 + 1))[:n_catch]
    order = rng.permutation(n_catch)
    out: list[tuple[str, ConditionPair, str]] = []
    for number, slot in enumerate(slots):
        clip, pair = main[slot - 1]
        if kind == "identical":
            condition = pair.left if rng.random() < 0.5 else pair.right
            out.append((clip, ConditionPair(condition, condition), "undecided"))
        elif onscreen is not None:
            out.append((clip, onscreen, answers[int(order[number])]))
        else:
            same_clip = [p for c, p in main if c == clip]
            chosen = same_clip[int(rng.integers(len(same_clip)))]
            out.append((clip, chosen, answers[int(order[number])]))
    return out
