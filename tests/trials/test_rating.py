"""Rating designs: every participant rates each clip x condition once, the conditions' places
balanced over a cycle of lists, checks at the bottom of the scale; the study file's keys."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.trials.design import build_pairs
from app.trials.rating import (
    CATCH_EXPECTED,
    catch_passed,
    check_score,
    rating_lists,
    rating_schedule,
)
from app.trials.schedule import make_schedule, n_lists_for
from app.trials.stimuli import shown_stimuli
from app.trials.studyfile import parse_study

StudyData = Callable[[], dict[str, Any]]


@settings(max_examples=40, deadline=None)
@given(
    n_conditions=st.integers(1, 6),
    n_clips=st.integers(1, 4),
    seed=st.integers(0, 2**32),
    catch=st.integers(0, 3),
)
def test_every_clip_and_condition_once_and_places_balanced_over_a_cycle(
    n_conditions: int, n_clips: int, seed: int, catch: int
) -> None:
    conditions = [f"c{i}" for i in range(n_conditions)]
    clips = [f"s{i}" for i in range(n_clips)]
    cycle = rating_lists(n_conditions)
    places: Counter[tuple[str, int]] = Counter()
    for list_index in range(cycle):
        trials = rating_schedule(
            clips=clips,
            conditions=conditions,
            seed=seed + list_index,
            list_index=list_index,
            n_lists=cycle,
            catch_trials=min(catch, n_conditions * n_clips),
        )
        main = [t for t in trials if t.kind == "trial"]
        assert [t.position for t in trials] == list(range(len(trials)))
        assert all(t.left == t.right for t in trials)
        assert sorted((t.clip, t.left) for t in main) == sorted(
            (s, c) for s in clips for c in conditions
        )
        for t in trials:
            if t.kind == "catch":
                before = trials[t.position - 1]
                assert (t.clip, t.left, t.expected) == (before.clip, before.left, CATCH_EXPECTED)
        for index, t in enumerate(main):
            places[(t.left, index % n_conditions)] += 1
    # every condition at every place of a block equally often over one cycle of lists
    assert set(places.values()) == {cycle * n_clips // n_conditions}


def test_known_schedule_and_list_count() -> None:
    assert rating_lists(4) == 4 and rating_lists(3) == 6 and rating_lists(1) == 1
    assert n_lists_for("rating", n_conditions=5) == 10
    pairs = build_pairs(["a", "b"], "rating")
    assert [(p.left, p.right) for p in pairs] == [("a", "a"), ("b", "b")]
    trials = make_schedule(
        clips=["s2", "s7"], pairs=pairs, design="rating", seed=1, list_index=1, n_lists=2
    )
    shown = [(t.clip, t.left) for t in trials]
    assert shown == [("s2", "b"), ("s7", "a"), ("s7", "b"), ("s2", "a")]
    # every single-face clip is rendered once
    assert shown_stimuli(clips=["s2", "s7"], pairs=pairs, design="rating") == [
        (clip, p) for clip in ("s2", "s7") for p in pairs
    ]
    with pytest.raises(ValueError, match="multiple of 2"):
        rating_schedule(clips=["s2"], conditions=["a", "b"], seed=0, list_index=0, n_lists=3)


def test_scores_and_checks() -> None:
    assert check_score("acr5", 5) == 5 and check_score("slider", 0.0) == 0
    for scale, bad in (("acr5", 0), ("acr5", 6), ("slider", 101), ("slider", 2.5), ("acr5", True)):
        with pytest.raises(ValueError, match="whole number"):
            check_score(scale, bad)
    assert catch_passed("acr5", 1) and not catch_passed("acr5", 2)
    assert catch_passed("slider", 10) and not catch_passed("slider", 11)


def _rating(data: dict[str, Any], **keys: Any) -> dict[str, Any]:
    data |= {"design": "rating", **keys}
    return data


def test_the_rating_design_in_a_study_file(make_study_data: StudyData, study_dir: Path) -> None:
    spec = parse_study(_rating(make_study_data()), base_dir=study_dir)
    assert spec.rating_scale == "acr5" and spec.practice is None
    assert spec.catch_kind == "instructed" and spec.n_lists() == 6
    assert len(spec.stimuli()) == 6 and len(spec.schedule(seed=3, list_index=2)) == 6
    slider = parse_study(
        _rating(make_study_data(), rating={"scale": "slider"}, catch={"trials": 2}),
        base_dir=study_dir,
    )
    assert slider.rating_scale == "slider" and len(slider.schedule(seed=0, list_index=0)) == 8
    again = parse_study(slider.to_dict(), base_dir=study_dir)
    assert again == slider


@pytest.mark.parametrize(
    ("keys", "field"),
    [
        ({"rating": {"scale": "acr7"}}, "rating.scale: expected one of acr5, slider"),
        ({"rating": {"steps": 5}}, "rating"),
        ({"catch": {"trials": 1, "kind": "identical"}}, "catch.kind"),
        ({"practice": ["none", "random"]}, "practice: design = 'rating' has no practice"),
        ({"mismatched": True}, "mismatched: only applies to the pair designs"),
    ],
)
def test_rating_mistakes_are_one_line_naming_the_key(
    make_study_data: StudyData, study_dir: Path, keys: dict[str, Any], field: str
) -> None:
    with pytest.raises(InputError) as caught:
        parse_study(_rating(make_study_data(), **keys), base_dir=study_dir)
    text = str(caught.value)
    assert "\n" not in text and f"study.toml: {field}" in text


def test_the_rating_table_belongs_to_the_rating_design(
    make_study_data: StudyData, study_dir: Path
) -> None:
    data = make_study_data() | {"rating": {"scale": "slider"}}
    with pytest.raises(InputError, match="rating: only applies to designs 'rating' and"):
        parse_study(data, base_dir=study_dir)


@settings(max_examples=60, deadline=None)
@given(
    value=st.one_of(
        st.none(),
        st.booleans(),
        st.integers(),
        st.floats(),
        st.text(max_size=8),
        st.lists(st.integers(), max_size=2),
        st.dictionaries(st.text(max_size=5), st.integers()),
    )
)
def test_any_rating_scale_value_is_read_or_refused_in_one_line(value: Any) -> None:
    data = {
        "title": "t",
        "question": "q",
        "design": "rating",
        "rating": {"scale": value},
        "conditions": [{"name": "a", "model": "none"}, {"name": "b", "model": "none"}],
        "clips": [{"name": "s2", "audio": "s2.wav"}],
    }
    try:
        spec = parse_study(data, check_files=False)
    except InputError as exc:
        assert "\n" not in str(exc) and "rating" in str(exc)
    else:
        assert spec.rating_scale == value


def test_the_parallel_design_shows_every_clip_once_in_a_balanced_order() -> None:
    from app.trials.rating import parallel_lists, parallel_order

    clips = ["s1", "s2", "s3"]
    cycle = parallel_lists(len(clips))
    places: Counter[tuple[str, int]] = Counter()
    for list_index in range(cycle):
        trials = make_schedule(
            clips=clips,
            pairs=build_pairs(["a", "b", "gt"], "parallel", reference="gt"),
            design="parallel",
            seed=5,
            list_index=list_index,
            n_lists=n_lists_for("parallel", n_clips=3),
            reference="gt",
        )
        assert sorted(t.clip for t in trials) == clips
        assert all(t.left == t.right == "gt" and t.kind == "trial" for t in trials)
        places.update((t.clip, t.position) for t in trials)
    assert set(places.values()) == {cycle // len(clips)}
    shown = parallel_order(["a", "b", "gt"], seed=5, position=1)
    assert sorted(shown) == ["a", "b", "gt"]
    assert shown == parallel_order(["a", "b", "gt"], seed=5, position=1)
    orders = {tuple(parallel_order(["a", "b", "gt"], seed=5, position=p)) for p in range(12)}
    assert len(orders) > 1  # shuffled per trial


def test_the_parallel_design_in_a_study_file(make_study_data: StudyData, study_dir: Path) -> None:
    data = make_study_data() | {"design": "parallel", "reference": "ground_truth"}
    spec = parse_study(data, base_dir=study_dir)
    assert (spec.rating_scale, spec.catch_trials, spec.practice) == ("slider", 0, None)
    assert spec.n_lists() == 2 and len(spec.stimuli()) == 6
    assert [t.left for t in spec.schedule(seed=1, list_index=0)] == ["ground_truth"] * 2
    assert parse_study(spec.to_dict(), base_dir=study_dir) == spec


@pytest.mark.parametrize(
    ("keys", "field"),
    [
        ({}, "reference: missing (required by design = 'parallel')"),
        ({"reference": "x"}, "reference: expected one of the conditions"),
        ({"reference": "none", "catch": {"trials": 1}}, "catch.trials: design = 'parallel'"),
        ({"reference": "none", "rating": {"scale": "acr5"}}, "rating.scale: design = 'parallel'"),
        (
            {"reference": "none", "replay": {"policy": "play_to_end"}},
            "replay.policy: design = 'parallel'",
        ),
        ({"reference": "none", "practice": ["none", "random"]}, "practice: design = 'parallel'"),
    ],
)
def test_parallel_mistakes_are_one_line_naming_the_key(
    make_study_data: StudyData, study_dir: Path, keys: dict[str, Any], field: str
) -> None:
    with pytest.raises(InputError) as caught:
        parse_study(make_study_data() | {"design": "parallel", **keys}, base_dir=study_dir)
    text = str(caught.value)
    assert "\n" not in text and f"study.toml: {field}" in text
