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
    (Williams design) chosen by the list, so across lists every clip comes at every position
    equally often and follows every other clip equally often.

Sides
    ``all_ordered`` already holds both side orders of every pair (thesis, TABLE 3), so every
    participant sees both. For ``reference`` and ``unordered_counterbalanced`` each participant
    sees each comparison once per clip; its side comes from a balanced orientation of the
    comparison graph (an Euler circuit: every condition is on the left as often as on the right,
    within one), alternated from clip to clip, and flipped entirely for odd lists, so lists
    ``2k`` and ``2k+1`` together show every pair of every clip in both orders.

Catch trials (``kind="catch"``) are spread evenly through the schedule and record the answer an
attentive participant gives in ``ScheduledTrial.expected`` (see :data:`CATCH_KINDS`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Final

import numpy as np

from app.trials.design import RATING_DESIGNS, ConditionPair, check_design, stimulus_pairs

TRIAL_KINDS: Final = ("practice", "trial", "catch", "mismatch")
"""Kinds of trial: the practice pair after the instructions, a real trial, a catch trial, an
appropriateness pair (one condition's motion for this clip beside its motion for another
clip, under this clip's speech: the GENEA challenge's appropriateness test)."""

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


@dataclass(frozen=True, slots=True)
class ScheduledTrial:
    """One page of the study.

    Attributes
    ----------
    position:
        0-based place in the participant's schedule, consecutive over all kinds (the practice
        trial, if any, is position 0); the web layer resumes at the lowest unanswered position.
    clip:
        Name of the clip (the audio segment) both panels play.
    left, right:
        Condition names shown on the left and right panels.
    kind:
        One of :data:`TRIAL_KINDS`.
    expected:
        For a catch trial, the answer an attentive participant gives (a value of
        ``app.trials.rules.CHOICES``); for an appropriateness pair, the side whose motion
        belongs to the speech; ``None`` otherwise.
    instruction:
        For an ``onscreen`` catch trial, the side the clip tells the participant to press.
    foreign:
        For an appropriateness pair, the side showing another clip's motion
        (:func:`foreign_clip`); ``""`` otherwise.
    """

    position: int
    clip: str
    left: str
    right: str
    kind: str = "trial"
    expected: str | None = None
    instruction: str = ""
    foreign: str = ""

    @property
    def pair(self) -> ConditionPair:
        """The displayed pair."""
        return ConditionPair(self.left, self.right)

    def catch_passed(self, choice: str) -> bool | None:
        """For a catch trial, whether ``choice`` is the expected answer; ``None`` otherwise."""
        if self.kind != "catch":
            return None
        return choice == self.expected


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
        from app.trials.rating import parallel_lists, rating_lists

        return parallel_lists(n_clips) if design == "parallel" else rating_lists(n_conditions)
    if n_clips < 1:
        raise ValueError(f"need at least one clip, got {n_clips}")
    rows = len(williams_square(n_clips)) if block_by_clip else 1
    return _side_lists(design) * rows


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
        Number of catch trials of kind ``catch_kind`` (:data:`CATCH_KINDS`), spread evenly.
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
    if design == "parallel":
        from app.trials.rating import parallel_schedule

        if reference is None:
            raise ValueError("design 'parallel' needs its reference condition")
        return parallel_schedule(
            clips=clips, reference=reference, list_index=list_index, n_lists=n_lists
        )
    if design in RATING_DESIGNS:
        from app.trials.rating import rating_schedule

        return rating_schedule(
            clips=clips,
            conditions=[p.left for p in pairs],
            seed=seed,
            list_index=list_index,
            n_lists=n_lists,
            catch_trials=catch_trials,
        )
    clips = list(clips)
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

    rng = np.random.default_rng(seed)
    sides = _side_lists(design)
    flip_list = sides == 2 and list_index % 2 == 1
    rows = williams_square(len(clips)) if block_by_clip else [list(range(len(clips)))]
    block_order = rows[(list_index // sides) % len(rows)]
    comparisons = _comparisons(pairs, design)

    blocks: list[list[tuple[str, ConditionPair]]] = []
    for clip_number in block_order:
        clip = clips[clip_number]
        flip = flip_list != (sides == 2 and clip_number % 2 == 1)
        shown = [p.flipped() if flip else p for p in comparisons]
        blocks.append([(clip, p) for p in shown])
    # adaptive: half the comparisons per clip, whose pairs the votes then choose
    keep = adaptive_trials_per_clip(len(comparisons)) if design == "adaptive" else None
    if block_by_clip:
        main = [block[i] for block in blocks for i in rng.permutation(len(block))[:keep]]
    else:
        flat = [item for block in blocks for item in block]
        main = [flat[i] for i in rng.permutation(len(flat))]
        if keep is not None:
            main = main[: keep * len(blocks)]

    slots = catch_slots(len(main), catch_trials, rng)
    onscreen = stimulus_pairs(pairs, design)[0] if catch_kind == "onscreen" else None
    catches = _catch_trials(main, slots, catch_kind, rng, onscreen)
    sequence: list[ScheduledTrial] = []
    if practice_pair is not None:
        clip = practice_clip if practice_clip is not None else main[0][0]
        sequence.append(
            ScheduledTrial(0, clip, practice_pair.left, practice_pair.right, "practice")
        )
    pending = 0
    for index, (clip, pair) in enumerate(main):
        sequence.append(ScheduledTrial(0, clip, pair.left, pair.right))
        while pending < len(slots) and slots[pending] == index + 1:
            c_clip, c_pair, expected = catches[pending]
            sequence.append(
                ScheduledTrial(
                    0,
                    c_clip,
                    c_pair.left,
                    c_pair.right,
                    "catch",
                    expected,
                    expected if onscreen is not None else "",
                )
            )
            pending += 1
    if mismatched:
        sequence = _with_mismatched(
            sequence, clips, pairs, rng, first=int(practice_pair is not None)
        )
    return [replace(trial, position=position) for position, trial in enumerate(sequence)]


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


def shown_stimuli(
    *,
    clips: Sequence[str],
    pairs: Sequence[ConditionPair],
    design: str,
    catch_trials: int = 0,
    catch_kind: str = "identical",
    practice_pair: ConditionPair | None = None,
    practice_clip: str | None = None,
) -> list[tuple[str, ConditionPair]]:
    """Every (clip, displayed pair) that some participant's schedule can show: the clips to render.

    The design's pairs in both orders where the lists flip sides
    (:func:`app.trials.design.stimulus_pairs`) on every clip; with ``identical`` catch trials
    also each condition against itself on every clip; the practice pair on ``practice_clip``, or
    on every clip when the first block decides. ``instructed`` catch trials reuse shown pairs.

    >>> from app.trials.design import build_pairs
    >>> len(shown_stimuli(clips=["s2", "s7"], pairs=build_pairs(["a", "b", "c"],
    ...     "unordered_counterbalanced"), design="unordered_counterbalanced"))
    12
    """
    shown = dict.fromkeys((clip, pair) for clip in clips for pair in stimulus_pairs(pairs, design))
    if catch_trials and catch_kind == "identical":
        conditions = dict.fromkeys(c for pair in pairs for c in (pair.left, pair.right))
        shown |= dict.fromkeys((clip, ConditionPair(c, c)) for clip in clips for c in conditions)
    if practice_pair is not None:
        on = [practice_clip] if practice_clip is not None else list(clips)
        shown |= dict.fromkeys((clip, practice_pair) for clip in on)
    return list(shown)


def variant_stimuli(
    *,
    clips: Sequence[str],
    pairs: Sequence[ConditionPair],
    design: str,
    catch_trials: int = 0,
    catch_kind: str = "identical",
    mismatched: bool = False,
) -> list[tuple[str, ConditionPair, str, str]]:
    """The clips to render besides :func:`shown_stimuli`: ``(clip, pair, instruction,
    foreign side)`` for ``onscreen`` catch trials (the design's first displayed pair with
    "press Left" and with "press Right" drawn in) and for appropriateness pairs (each
    condition against itself with the mismatched motion on either side).

    >>> from app.trials.design import build_pairs
    >>> len(variant_stimuli(clips=["s2", "s7"], pairs=build_pairs(["a", "b"], "all_ordered"),
    ...                     design="all_ordered", mismatched=True))
    8
    """
    out: list[tuple[str, ConditionPair, str, str]] = []
    if catch_trials and catch_kind == "onscreen":
        pair = stimulus_pairs(pairs, design)[0]
        out += [(clip, pair, side, "") for clip in clips for side in ("left", "right")]
    if mismatched:
        conditions = dict.fromkeys(c for pair in pairs for c in (pair.left, pair.right))
        out += [
            (clip, ConditionPair(c, c), "", side)
            for clip in clips
            for c in conditions
            for side in ("left", "right")
        ]
    return out


def catch_slots(n_main: int, n_catch: int, rng: np.random.Generator) -> list[int]:
    """After how many main trials each catch trial comes: one per equal segment, never first."""
    if n_catch == 0:
        return []
    if n_catch > n_main:
        raise ValueError(f"{n_catch} catch trials do not fit among {n_main} trials")
    edges = [math.floor(i * n_main / n_catch) for i in range(n_catch + 1)]
    return [int(rng.integers(lo, hi)) + 1 for lo, hi in zip(edges[:-1], edges[1:], strict=True)]


def _catch_trials(
    main: Sequence[tuple[str, ConditionPair]],
    slots: Sequence[int],
    kind: str,
    rng: np.random.Generator,
    onscreen: ConditionPair | None = None,
) -> list[tuple[str, ConditionPair, str]]:
    """Stimuli and expected answers of the catch trials, each on the clip of the trial before.

    ``identical`` shows one of the two conditions of the preceding trial on both sides;
    ``instructed`` repeats a random pair of the same clip, half of them to be answered ``left``.
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
