"""The stimuli to render: every clip any list and seed can show, and nothing more."""

from __future__ import annotations

import doctest

from hypothesis import given, settings
from hypothesis import strategies as st

from app.trials import stimuli as stimuli_module
from app.trials.catch import CATCH_KINDS
from app.trials.design import PAIR_DESIGNS, ConditionPair, build_pairs, stimulus_pairs
from app.trials.schedule import make_schedule, n_lists_for
from app.trials.stimuli import shown_stimuli

designs = st.sampled_from([d for d in PAIR_DESIGNS if d != "adaptive"])
n_conditions = st.integers(2, 6)
n_clips = st.integers(1, 4)


def test_docstring_examples() -> None:
    assert doctest.testmod(stimuli_module).failed == 0


@settings(max_examples=40, deadline=None)
@given(
    designs, n_conditions, n_clips, st.integers(0, 3), st.sampled_from(CATCH_KINDS), st.booleans()
)
def test_shown_stimuli_cover_every_schedule_and_nothing_more(
    design: str, n: int, m: int, n_catch: int, catch_kind: str, practice_on_clip: bool
) -> None:
    conditions = [f"c{i}" for i in range(n)]
    clips = [f"s{j}" for j in range(m)]
    reference = conditions[-1] if design == "reference" else None
    pairs = build_pairs(conditions, design, reference=reference)
    n_catch = min(n_catch, m * (n - 1))
    practice = ConditionPair(conditions[0], conditions[1])
    practice_clip = clips[-1] if practice_on_clip else None
    options = dict(
        clips=clips,
        pairs=pairs,
        design=design,
        catch_trials=n_catch,
        catch_kind=catch_kind,
        practice_pair=practice,
        practice_clip=practice_clip,
    )
    stimuli = shown_stimuli(**options)  # type: ignore[arg-type]
    assert len(stimuli) == len(set(stimuli))
    n_lists = n_lists_for(design, n_clips=m)
    seen: set[tuple[str, ConditionPair]] = set()
    for seed in range(6):
        for k in range(n_lists):
            trials = make_schedule(seed=seed, list_index=k, n_lists=n_lists, **options)  # type: ignore[arg-type]
            seen |= {(t.clip, t.pair) for t in trials}
    assert seen <= set(stimuli)
    every_main = {(c, p) for c in clips for p in stimulus_pairs(pairs, design)}
    assert every_main <= seen  # nothing to render that no list shows
