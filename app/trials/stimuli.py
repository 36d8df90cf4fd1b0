"""The stimuli a study renders: every clip some participant's schedule can show.

The renderer draws each (clip, displayed pair) once, before anyone takes part, so the set must
hold whatever any list and any seed of :func:`app.trials.schedule.make_schedule` can show and
nothing more: the design's pairs on every clip (in both orders where the lists flip sides, as
the thesis' TABLE 3 holds both orders of a pair), each condition against itself for
``identical`` catch trials, and the practice pair (:func:`shown_stimuli`); then the variants
with something drawn into the clip: the instruction of an ``onscreen`` catch trial and the
mismatched motion of an appropriateness pair, the GENEA challenge's appropriateness test
(:func:`variant_stimuli`).
"""

from __future__ import annotations

from collections.abc import Sequence

from app.trials.design import ConditionPair, stimulus_pairs


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
