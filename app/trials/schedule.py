"""Participant schedules: which clip and pair each trial shows, in which order and on which side.

A schedule is a pure function of the study design, the participant's stored seed and the list
the participant was assigned to (:mod:`app.trials.assignment`), so a reload or a resumed link
rebuilds exactly the same sequence of trials.

Three things are counterbalanced, each following a seed study:

Order of trials
    Randomised per participant from the stored seed with a numpy ``Generator``: the thesis
    (sec. 5.2) presented the pairs "in a random order" "to discard any bias due presentation
    order", and Le, Ma & Deng 2012 (sec. 8.1) displayed them "in a random order for each
    participant".

Order of clips
    With ``block_by_clip`` (the default) the trials of one clip form a block, as in the thesis
    (sec. 5.2, TABLE 3: all pairs of segment S2, then all pairs of S7; sec. 5.3 ran six surveys
    with S7 first and eight with S2 first). The block order is a row of a balanced Latin square
    (Williams design, :func:`app.trials.counterbalance.williams_square`) chosen by the list, so
    across lists every clip comes at every position equally often and follows every other clip
    equally often.

Sides
    ``all_ordered`` already holds both side orders of every pair (thesis, TABLE 3), so every
    participant sees both. For ``reference`` and ``unordered_counterbalanced`` each participant
    sees each comparison once per clip; its side comes from a balanced orientation of the
    comparison graph (an Euler circuit, :func:`app.trials.counterbalance.balanced_orientation`:
    every condition is on the left as often as on the right, within one), alternated from clip
    to clip, and flipped entirely for odd lists, so lists ``2k`` and ``2k+1`` together show
    every pair of every clip in both orders.

Catch trials (``kind="catch"``) are spread evenly through the schedule and record the answer an
attentive participant gives in ``ScheduledTrial.expected`` (see :mod:`app.trials.catch`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from app.trials.catch import CATCH_KINDS, catch_slots, catch_stimuli
from app.trials.counterbalance import balanced_orientation, williams_square
from app.trials.design import RATING_DESIGNS, ConditionPair, check_design, stimulus_pairs
from app.trials.rating import parallel_lists, parallel_schedule, rating_lists, rating_schedule
from app.trials.trial import ScheduledTrial


def participant_seed(study_seed: int, participant_number: int) -> int:
    """Derive a participant's schedule seed from the study seed, independent per participant.

    Uses numpy's ``SeedSequence`` spawn keys, so seeds of participants 0, 1, 2, ... are
    statistically independent streams and stable across numpy versions. Store the result on the
    participant's row; :func:`make_schedule` takes it as ``seed``.

    >>> participant_seed(7, 0) == participant_seed(7, 0) != participant_seed(7, 1)
    True
    """
    if study_seed < 0 or participant_number < 0:
        raise ValueError("study_seed and participant_number must be non-negative")
    sequence = np.random.SeedSequence(entropy=study_seed, spawn_key=(participant_number,))
    return int(sequence.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))


def _side_lists(design: str) -> int:
    return 1 if design == "all_ordered" else 2


def n_lists_for(
    design: str, *, n_clips: int = 1, block_by_clip: bool = True, n_conditions: int = 2
) -> int:
    """The number of lists that completes one full counterbalancing cycle.

    ``rating``: one list per row of the Williams square of the ``n_conditions`` conditions
    (:func:`app.trials.rating.rating_lists`); ``parallel``: of the clips; the pair designs:
    ``sides x block orders``: sides need 1 list for ``all_ordered`` (both orders are in every
    schedule) and 2 otherwise (one list per side order); block orders need one row of the
    Williams square per list (``n_clips`` rows, ``2 n_clips`` for odd ``n_clips > 1``) when
    trials are blocked by clip, else 1. Balanced assignment over this many lists shows every
    pair in both orders and every clip at every position equally often.

    >>> n_lists_for("all_ordered", n_clips=2), n_lists_for("reference", n_clips=3)
    (2, 12)
    """
    check_design(design)
    if design in RATING_DESIGNS:
        return parallel_lists(n_clips) if design == "parallel" else rating_lists(n_conditions)
    if n_clips < 1:
        raise ValueError(f"need at least one clip, got {n_clips}")
    rows = len(williams_square(n_clips)) if block_by_clip else 1
    return _side_lists(design) * rows


def _comparisons(pairs: Sequence[ConditionPair], design: str) -> list[ConditionPair]:
    """The pairs one participant sees per clip, before the list's side flip."""
    if design == "all_ordered":
        return list(dict.fromkeys(pairs))
    seen: dict[frozenset[str], ConditionPair] = {}
    for pair in pairs:
        if pair.is_same:
            raise ValueError(f"design {design!r} has no same-condition pairs, got {pair}")
        seen.setdefault(pair.conditions, pair)
    return balanced_orientation(list(seen.values()))


def make_schedule(
    *,
    clips: Sequence[str],
    pairs: Sequence[ConditionPair],
    design: str,
    seed: int,
    list_index: int,
    n_lists: int,
    catch_trials: int = 0,
    practice_pair: ConditionPair | None = None,
    catch_kind: str = "identical",
    practice_clip: str | None = None,
    block_by_clip: bool = True,
    mismatched: bool = False,
    reference: str | None = None,
) -> list[ScheduledTrial]:
    """Build one participant's schedule; pure and deterministic in all its arguments.

    Parameters
    ----------
    clips:
        Distinct clip names, in the study's order.
    pairs:
        The design's pairs from :func:`app.trials.design.build_pairs`.
    design:
        The design that produced ``pairs``; ``rating`` is scheduled by
        :func:`app.trials.rating.rating_schedule` (the conditions are the pairs' ``left``),
        ``parallel`` by :func:`app.trials.rating.parallel_schedule` with ``reference``.
    seed:
        The participant's stored seed (:func:`participant_seed`); drives trial order and catch
        trial placement through ``numpy.random.default_rng(seed)``.
    list_index, n_lists:
        The participant's list and the number of lists; ``n_lists`` must be a multiple of
        :func:`n_lists_for` so that every list maps to one side order and one block order.
    catch_trials:
        Number of catch trials of kind ``catch_kind`` (:data:`app.trials.catch.CATCH_KINDS`),
        spread evenly.
    practice_pair, practice_clip:
        An optional practice trial at position 0 (clip defaults to the first clip shown).
    block_by_clip:
        Keep each clip's trials together, blocks ordered by a Williams-square row (thesis
        sec. 5.2-5.3); ``False`` shuffles all trials together.
    mismatched:
        Add one appropriateness pair per condition and clip (kind ``"mismatch"``, needs two
        clips), each at a random place; drawn after everything else, so the rest of the
        schedule is the same with or without them.

    Returns
    -------
    The trials in presentation order, ``position`` 0, 1, 2, ...

    >>> from app.trials.design import build_pairs
    >>> pairs = build_pairs(["a", "b", "c"], "unordered_counterbalanced")
    >>> s0 = make_schedule(clips=["s2"], pairs=pairs, design="unordered_counterbalanced",
    ...                    seed=1, list_index=0, n_lists=2)
    >>> s1 = make_schedule(clips=["s2"], pairs=pairs, design="unordered_counterbalanced",
    ...                    seed=1, list_index=1, n_lists=2)
    >>> sorted(t.pair for t in s0) == sorted(t.pair.flipped() for t in s1)
    True
    """
    check_design(design)
    if design in RATING_DESIGNS:
        return _rating_design_schedule(
            clips=clips,
            pairs=pairs,
            design=design,
            seed=seed,
            list_index=list_index,
            n_lists=n_lists,
            catch_trials=catch_trials,
            reference=reference,
        )
    clips = list(clips)
    _check_pair_schedule(
        clips,
        pairs,
        design,
        list_index=list_index,
        n_lists=n_lists,
        catch_trials=catch_trials,
        catch_kind=catch_kind,
        block_by_clip=block_by_clip,
    )
    rng = np.random.default_rng(seed)
    comparisons = _comparisons(pairs, design)
    blocks = _clip_blocks(clips, comparisons, design, list_index, block_by_clip=block_by_clip)
    # adaptive: half the comparisons per clip, whose pairs the votes then choose
    keep = adaptive_trials_per_clip(len(comparisons)) if design == "adaptive" else None
    main = _shuffled_trials(blocks, rng, block_by_clip=block_by_clip, keep=keep)
    onscreen = stimulus_pairs(pairs, design)[0] if catch_kind == "onscreen" else None
    with_catches = _with_catch_trials(main, catch_trials, catch_kind, rng, onscreen)
    sequence = _practice(practice_pair, practice_clip, main) + with_catches
    if mismatched:
        sequence = _with_mismatched(
            sequence, clips, pairs, rng, first=int(practice_pair is not None)
        )
    return [replace(trial, position=position) for position, trial in enumerate(sequence)]


def _practice(
    pair: ConditionPair | None, clip: str | None, main: Sequence[tuple[str, ConditionPair]]
) -> list[ScheduledTrial]:
    """The practice trial, if there is a ``pair`` to practise on: on ``clip``, else on the
    clip of the first real trial."""
    if pair is None:
        return []
    return [
        ScheduledTrial(0, main[0][0] if clip is None else clip, pair.left, pair.right, "practice")
    ]


def _rating_design_schedule(
    *,
    clips: Sequence[str],
    pairs: Sequence[ConditionPair],
    design: str,
    seed: int,
    list_index: int,
    n_lists: int,
    catch_trials: int,
    reference: str | None,
) -> list[ScheduledTrial]:
    """The schedule of a rating design (:mod:`app.trials.rating`): ``parallel`` around its
    ``reference``, ``rating`` over the conditions, which are the pairs' ``left``."""
    if design == "parallel":
        if reference is None:
            raise ValueError("design 'parallel' needs its reference condition")
        return parallel_schedule(
            clips=clips, reference=reference, list_index=list_index, n_lists=n_lists
        )
    return rating_schedule(
        clips=clips,
        conditions=[p.left for p in pairs],
        seed=seed,
        list_index=list_index,
        n_lists=n_lists,
        catch_trials=catch_trials,
    )


def _check_pair_schedule(
    clips: Sequence[str],
    pairs: Sequence[ConditionPair],
    design: str,
    *,
    list_index: int,
    n_lists: int,
    catch_trials: int,
    catch_kind: str,
    block_by_clip: bool,
) -> None:
    """Raise ``ValueError`` for arguments no pair-design schedule can be built from."""
    if not clips or len(set(clips)) != len(clips):
        raise ValueError("clips must be a non-empty list of distinct names")
    if not pairs:
        raise ValueError("no pairs to schedule")
    if catch_kind not in CATCH_KINDS:
        raise ValueError(
            f"catch_kind: expected one of {', '.join(CATCH_KINDS)}, got {catch_kind!r}"
        )
    if catch_trials < 0:
        raise ValueError(f"catch_trials must be >= 0, got {catch_trials}")
    cycle = n_lists_for(design, n_clips=len(clips), block_by_clip=block_by_clip)
    if n_lists < 1 or n_lists % cycle:
        raise ValueError(f"n_lists must be a positive multiple of {cycle}, got {n_lists}")
    if not 0 <= list_index < n_lists:
        raise ValueError(f"list_index must be in 0..{n_lists - 1}, got {list_index}")


def _clip_blocks(
    clips: Sequence[str],
    comparisons: Sequence[ConditionPair],
    design: str,
    list_index: int,
    *,
    block_by_clip: bool,
) -> list[list[tuple[str, ConditionPair]]]:
    """The list's counterbalancing of clips and sides: one block of (clip, displayed pair) per
    clip, in the order of the list's Williams row; sides alternate from clip to clip and odd
    lists flip them all, where the design does not already show both orders."""
    sides = _side_lists(design)
    flip_list = sides == 2 and list_index % 2 == 1
    rows = williams_square(len(clips)) if block_by_clip else [list(range(len(clips)))]
    blocks = []
    for clip_number in rows[(list_index // sides) % len(rows)]:
        flip = flip_list != (sides == 2 and clip_number % 2 == 1)
        shown = [p.flipped() if flip else p for p in comparisons]
        blocks.append([(clips[clip_number], p) for p in shown])
    return blocks


def _shuffled_trials(
    blocks: Sequence[Sequence[tuple[str, ConditionPair]]],
    rng: np.random.Generator,
    *,
    block_by_clip: bool,
    keep: int | None,
) -> list[tuple[str, ConditionPair]]:
    """The participant's random order of trials: within each block, or over all blocks
    together; with ``keep``, only that many per block (the ``adaptive`` design)."""
    if block_by_clip:
        return [block[i] for block in blocks for i in rng.permutation(len(block))[:keep]]
    flat = [item for block in blocks for item in block]
    main = [flat[i] for i in rng.permutation(len(flat))]
    return main if keep is None else main[: keep * len(blocks)]


def _with_catch_trials(
    main: Sequence[tuple[str, ConditionPair]],
    catch_trials: int,
    catch_kind: str,
    rng: np.random.Generator,
    onscreen: ConditionPair | None,
) -> list[ScheduledTrial]:
    """The real trials with ``catch_trials`` catch trials among them (:mod:`app.trials.catch`);
    an ``onscreen`` one carries its expected side as the clip's instruction."""
    slots = catch_slots(len(main), catch_trials, rng)
    placed: dict[int, list[ScheduledTrial]] = {}
    for after, (clip, pair, expected) in zip(
        slots, catch_stimuli(main, slots, catch_kind, rng, onscreen), strict=True
    ):
        instruction = expected if onscreen is not None else ""
        catch = ScheduledTrial(0, clip, pair.left, pair.right, "catch", expected, instruction)
        placed.setdefault(after, []).append(catch)
    sequence = []
    for index, (clip, pair) in enumerate(main, start=1):
        sequence.append(ScheduledTrial(0, clip, pair.left, pair.right))
        sequence += placed.get(index, [])
    return sequence


def adaptive_trials_per_clip(n_pairs: int) -> int:
    """Trials per clip of an ``adaptive`` schedule: half the unordered pairs, rounded up.

    >>> adaptive_trials_per_clip(28), adaptive_trials_per_clip(3)
    (14, 2)
    """
    return (n_pairs + 1) // 2


def foreign_clip(clips: Sequence[str], clip: str) -> str:
    """The clip whose motion an appropriateness pair on ``clip`` shows as the mismatched
    side: the next clip in the study's order (cyclic), so every clip lends its motion once.

    >>> foreign_clip(["s2", "s7", "s9"], "s9")
    's2'
    """
    index = list(clips).index(clip)
    return clips[(index + 1) % len(clips)]


def _with_mismatched(
    sequence: list[ScheduledTrial],
    clips: Sequence[str],
    pairs: Sequence[ConditionPair],
    rng: np.random.Generator,
    *,
    first: int,
) -> list[ScheduledTrial]:
    """Insert one appropriateness pair per condition and clip at random places after
    ``first``; the mismatched side is balanced (left and right equally often, within one)."""
    if len(clips) < 2:
        raise ValueError("appropriateness pairs need at least two clips")
    conditions = list(dict.fromkeys(c for pair in pairs for c in (pair.left, pair.right)))
    items = [(clip, c) for clip in clips for c in conditions]
    sides = (["left", "right"] * (len(items) // 2 + 1))[: len(items)]
    sides = [sides[i] for i in rng.permutation(len(sides))]
    out = list(sequence)
    for (clip, condition), side in zip(items, sides, strict=True):
        matched = "right" if side == "left" else "left"
        at = int(rng.integers(first, len(out) + 1))
        out.insert(at, ScheduledTrial(0, clip, condition, condition, "mismatch", matched, "", side))
    return out
