"""Pair designs: which conditions are compared with which, and on which side.

Four pair designs, the first three taken from a seed study, and two rating designs:

``all_ordered``
    Every ordered pair of conditions, same-condition pairs included: n^2 pairs for n conditions.
    This is the design of the thesis, sec. 5.2 (Experiment 1): four models presented "in a
    pair-wise fashion, for a total of 32 pairs (4x4 combinations, times two segments)", TABLE 3
    listing both RANDOM/SPEECH_DRIVEN and SPEECH_DRIVEN/RANDOM as well as SPEECH_DRIVEN/
    SPEECH_DRIVEN. Both side orders are shown to every participant, so position bias cancels
    within each participant, and the same-condition pairs measure pure side preference.

``reference``
    Every other condition against one reference condition, in both side orders: 2(n-1) pairs.
    This is the design of Le, Ma & Deng 2012, sec. 8.1.1: "10 pairs for the comparison between
    our approach and each of the other four approaches". The paper does not say how sides were
    assigned; here each comparison exists in both orders and the schedule shows each participant
    one order per clip, the other order to the complementary list (see ``schedule``).

``unordered_counterbalanced``
    Each unordered pair of distinct conditions once: C(n, 2) pairs. The schedule decides the
    side per participant and flips it across lists, so every pair is seen in both orders across
    participants (the counterbalancing the 2012 paper, sec. 8.1, asks for: "To counter balance
    the order of the visual stimuli ...").

``adaptive``
    The pairs of ``unordered_counterbalanced``, rendered in both orders, of which each
    participant judges half per clip, each vote's next pair chosen by expected information gain
    under the posterior of the study's votes so far (ASAP, Mikhailiuk et al. 2021; see
    :mod:`app.trials.adaptive`), for studies of :data:`app.trials.adaptive.MIN_CONDITIONS` or
    more conditions.

``rating``
    No comparison: every condition's clip rated on its own (ITU-T P.910 ACR; see
    :mod:`app.trials.rating`). Its "pairs" are the conditions each against itself, what a
    single-face clip shows (``left == right``), so the rows and stimuli of the pair designs
    carry it unchanged.

``parallel``
    Every condition of one clip rated side by side on 0-100 sliders, the ``reference``
    condition among them hidden and also shown labelled (MUSHRA-like, ITU-R BS.1534-3); the
    "pairs" are those of ``rating``.

Conditions are named by their study names (e.g. ``"speech_driven"``); a ``ConditionPair`` is what
one side-by-side clip shows: ``left`` on the left panel, ``right`` on the right.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

PAIR_DESIGNS: Final = ("all_ordered", "reference", "unordered_counterbalanced", "adaptive")
"""The pair designs understood by :func:`build_pairs` and the schedule."""
RATING_DESIGNS: Final = ("rating", "parallel")
"""Designs that rate one condition at a time (:mod:`app.trials.rating`)."""
DESIGNS: Final = PAIR_DESIGNS + RATING_DESIGNS
"""Every design a study file may name."""
REFERENCE_DESIGNS: Final = ("reference", "parallel")
"""Designs that name a ``reference`` condition."""
UNORDERED_DESIGNS: Final = ("unordered_counterbalanced", "adaptive")
"""Designs of unordered pairs whose side the schedule chooses (both orders rendered)."""


@dataclass(frozen=True, order=True, slots=True)
class ConditionPair:
    """One side-by-side comparison: condition ``left`` on the left panel, ``right`` on the right.

    >>> ConditionPair("random", "speech_driven").flipped()
    ConditionPair(left='speech_driven', right='random')
    """

    left: str
    right: str

    def flipped(self) -> ConditionPair:
        """The same comparison with the sides exchanged."""
        return ConditionPair(self.right, self.left)

    @property
    def is_same(self) -> bool:
        """True for a same-condition pair (the thesis' NO_PROSODY/NO_PROSODY, TABLE 3)."""
        return self.left == self.right

    @property
    def conditions(self) -> frozenset[str]:
        """The unordered comparison this pair shows (one element for a same-condition pair)."""
        return frozenset((self.left, self.right))


def check_design(design: str) -> str:
    """Return ``design`` if it is one of :data:`DESIGNS`, else raise ``ValueError``."""
    if design not in DESIGNS:
        raise ValueError(f"expected one of {', '.join(DESIGNS)}, got {design!r}")
    return design


def build_pairs(
    conditions: Sequence[str], design: str, *, reference: str | None = None
) -> list[ConditionPair]:
    """List the pairs of a design, in a fixed order derived from the order of ``conditions``.

    Parameters
    ----------
    conditions:
        Distinct condition names, at least two (one is enough for nothing to compare).
    design:
        One of :data:`DESIGNS` (see the module docstring for the seed each follows).
    reference:
        The reference condition; required for ``"reference"`` and ``"parallel"`` and refused
        otherwise.

    Returns
    -------
    ``all_ordered``: n^2 pairs, row-major over (left, right), same-condition pairs included
    (thesis sec. 5.2, TABLE 3). ``reference``: 2(n-1) pairs, for each other condition ``c`` in
    order ``ConditionPair(c, reference)`` then ``ConditionPair(reference, c)`` (Le et al. 2012,
    sec. 8.1.1).
    ``rating``: n pairs ``ConditionPair(c, c)``, one single-face clip per condition.
    ``unordered_counterbalanced`` and ``adaptive``: C(n, 2) pairs ``ConditionPair(a, b)`` with ``a``
    before ``b`` in ``conditions``; the schedule chooses the displayed side.

    Raises
    ------
    ValueError
        Fewer than two conditions, duplicates, an unknown design, or a missing/unknown/unexpected
        reference.

    Examples
    --------
    >>> [(p.left, p.right) for p in build_pairs(["a", "b"], "all_ordered")]
    [('a', 'a'), ('a', 'b'), ('b', 'a'), ('b', 'b')]
    >>> [(p.left, p.right) for p in build_pairs(["a", "b", "r"], "reference", reference="r")]
    [('a', 'r'), ('r', 'a'), ('b', 'r'), ('r', 'b')]
    >>> len(build_pairs(["a", "b", "c", "d"], "unordered_counterbalanced"))
    6
    """
    check_design(design)
    names = list(conditions)
    if len(names) < 2:
        raise ValueError(f"a paired comparison needs at least two conditions, got {len(names)}")
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ValueError(f"condition names must be distinct, repeated: {', '.join(duplicates)}")
    if design in REFERENCE_DESIGNS:
        if reference is None:
            raise ValueError(f"design {design!r} needs a reference condition")
        if reference not in names:
            raise ValueError(
                f"reference {reference!r} is not one of the conditions {', '.join(names)}"
            )
    elif reference is not None:
        raise ValueError(
            f"a reference condition only applies to designs 'reference' and 'parallel', "
            f"not {design!r}"
        )

    if design == "all_ordered":
        return [ConditionPair(a, b) for a in names for b in names]
    if design in RATING_DESIGNS:
        return [ConditionPair(c, c) for c in names]
    if design == "reference":
        pairs: list[ConditionPair] = []
        for other in names:
            if other != reference:
                pairs += [ConditionPair(other, reference), ConditionPair(reference, other)]  # type: ignore[arg-type]
        return pairs
    return [ConditionPair(a, b) for i, a in enumerate(names) for b in names[i + 1 :]]


def stimulus_pairs(pairs: Sequence[ConditionPair], design: str) -> list[ConditionPair]:
    """Every ordered pair some participant may see: the side-by-side clips to render.

    For ``all_ordered`` and ``reference`` that is ``pairs`` itself (both orders are already
    there); for ``unordered_counterbalanced`` each pair is followed by its flipped twin, because
    the schedule shows one order to half of the lists and the other order to the rest.

    >>> stimulus_pairs([ConditionPair("a", "b")], "unordered_counterbalanced")
    [ConditionPair(left='a', right='b'), ConditionPair(left='b', right='a')]
    """
    check_design(design)
    if design not in UNORDERED_DESIGNS:
        return list(dict.fromkeys(pairs))
    out: dict[ConditionPair, None] = {}
    for pair in pairs:
        out[pair] = None
        out[pair.flipped()] = None
    return list(out)
