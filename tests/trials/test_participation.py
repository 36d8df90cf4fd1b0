"""The participant-side block of a study file, and the schedule's attention checks drawn into
the clip and appropriateness pairs."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.trials.design import build_pairs
from app.trials.participation import AudioCheckSpec, ParticipationSpec
from app.trials.schedule import foreign_clip, make_schedule
from app.trials.stimuli import variant_stimuli
from app.trials.studyfile import loads_study, parse_study


def _parse(data: dict[str, Any], base: Path):
    return parse_study(data, source="study.toml", base_dir=base)


def test_defaults_are_the_classic_page(make_study_data, study_dir) -> None:
    assert _parse(make_study_data(), study_dir).participation == ParticipationSpec()


def test_block_is_read_and_written_back(make_study_data, study_dir) -> None:
    data = make_study_data() | {
        "mismatched": True,
        "answer": {"scale": 5, "reasons": ["lips", "eyes"]},
        "attention": {"max_failed": 2, "screened_out_code": "RETURN-7"},
        "viewing": {"min_face_px": 160, "portrait": "rotate"},
        "language": "fr-CA",
        "audio_check": {"kind": "huggins", "trials": 8, "pass_mark": 7, "attempts": 2},
    }
    spec = _parse(data, study_dir)
    assert spec.participation == ParticipationSpec(
        scale=5,
        reasons=("lips", "eyes"),
        max_failed=2,
        screened_out_code="RETURN-7",
        min_face_px=160,
        portrait="rotate",
        mismatched=True,
        language="fr-CA",
        audio_check=AudioCheckSpec("huggins", trials=8, pass_mark=7, attempts=2),
    )
    again = loads_study(spec.to_toml(), base_dir=study_dir)
    assert again.participation == spec.participation
    stored = ParticipationSpec.from_settings(spec.participation.to_dict())
    assert stored == spec.participation


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        ({"answer": {"scale": 4}}, "answer.scale: expected 3 or 5, got 4"),
        ({"answer": {"scale": "5"}}, "answer.scale: expected an integer"),
        ({"answer": {"reasons": ["a", "a"]}}, "answer.reasons: repeats a tag"),
        ({"answer": {"reasons": ["ok", ""]}}, "answer.reasons[1]: expected a tag of 1 to 40"),
        ({"answer": {"reasons": [str(i) for i in range(9)]}}, "answer.reasons: at most 8 tags"),
        ({"answer": {"levels": 5}}, "answer.levels: unknown key"),
        ({"attention": {"max_failed": -1}}, "attention.max_failed: must be >= 0"),
        ({"viewing": {"portrait": "tilt"}}, "viewing.portrait: expected one of fit, rotate"),
        ({"viewing": {"min_face_px": 1.5}}, "viewing.min_face_px: expected an integer"),
        ({"mismatched": "yes"}, "mismatched: expected true or false"),
        ({"language": "german"}, "language: expected a BCP 47 tag such as 'de' or 'fr-CA'"),
        ({"language": "xx"}, "language: no catalogue for 'xx'; expected one of ar, de, en"),
        ({"language": 7}, "language: expected a string"),
        ({"audio_check": {"kind": "beep"}}, "audio_check.kind: expected one of none, huggins"),
        ({"audio_check": {"trials": 0}}, "audio_check.trials: must be >= 1"),
        ({"audio_check": {"trials": 4, "pass_mark": 5}}, "audio_check.pass_mark: at most"),
        ({"audio_check": {"attempts": 4}}, "audio_check.attempts: must be <= 3"),
        ({"audio_check": {"level": 1}}, "audio_check.level: unknown key"),
    ],
)
def test_each_bad_key_names_its_field(make_study_data, study_dir, changes, expected) -> None:
    with pytest.raises(InputError) as caught:
        _parse(make_study_data() | changes, study_dir)
    assert str(caught.value).startswith("study.toml: " + expected), str(caught.value)


def test_mismatched_needs_two_clips(make_study_data, study_dir) -> None:
    data = make_study_data() | {"mismatched": True}
    data["clips"] = data["clips"][:1]
    data["conditions"] = [c for c in data["conditions"] if c["name"] != "ground_truth"]
    with pytest.raises(InputError, match="mismatched: needs at least two clips"):
        _parse(data, study_dir)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    block=st.dictionaries(
        st.sampled_from(
            ["answer", "attention", "viewing", "mismatched", "language", "audio_check"]
        ),
        st.one_of(
            st.none(),
            st.integers(),
            st.text(max_size=5),
            st.dictionaries(
                st.text(max_size=12),
                st.one_of(
                    st.integers(), st.text(max_size=50), st.lists(st.text(max_size=50), max_size=10)
                ),
            ),
        ),
    )
)
def test_any_block_is_read_or_refused_in_one_line(make_study_data, study_dir, block) -> None:
    try:
        _parse(make_study_data() | block, study_dir)
    except InputError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("study.toml: ")


@given(tag=st.text(max_size=30))
@settings(
    max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
def test_any_language_is_kept_or_refused_in_one_line(make_study_data, study_dir, tag) -> None:
    try:
        spec = _parse(make_study_data() | {"language": tag}, study_dir)
    except InputError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("study.toml: language: ")
    else:
        assert spec.participation.language == tag
        assert tag.split("-")[0].lower() in ("ar", "de", "en", "es", "fr", "ja")


PAIRS = build_pairs(["a", "b", "c"], "all_ordered")


def _schedule(seed: int, **options):
    return make_schedule(
        clips=["s2", "s7"],
        pairs=PAIRS,
        design="all_ordered",
        seed=seed,
        list_index=0,
        n_lists=2,
        **options,
    )


def test_onscreen_catch_trials_carry_the_expected_side_as_instruction() -> None:
    trials = _schedule(3, catch_trials=4, catch_kind="onscreen")
    catches = [t for t in trials if t.kind == "catch"]
    assert len(catches) == 4
    assert all(t.instruction == t.expected and t.pair == PAIRS[0] for t in catches)
    assert Counter(t.expected for t in catches) == {"left": 2, "right": 2}
    shown = {
        (c, p, i)
        for c, p, i, _f in variant_stimuli(
            clips=["s2", "s7"],
            pairs=PAIRS,
            design="all_ordered",
            catch_trials=4,
            catch_kind="onscreen",
        )
    }
    assert {(t.clip, t.pair, t.instruction) for t in catches} <= shown


@given(seed=st.integers(0, 2**32))
@settings(max_examples=30, deadline=None)
def test_appropriateness_pairs_leave_the_rest_of_the_schedule_alone(seed: int) -> None:
    plain = _schedule(seed, catch_trials=2)
    mixed = _schedule(seed, catch_trials=2, mismatched=True)
    pairs = [t for t in mixed if t.kind == "mismatch"]
    assert [(t.clip, t.pair, t.kind) for t in mixed if t.kind != "mismatch"] == [
        (t.clip, t.pair, t.kind) for t in plain
    ]
    assert [t.position for t in mixed] == list(range(len(mixed)))
    # one per condition and clip, the same condition on both sides, the mismatched side
    # balanced, and the expected (matched) side the other one
    assert sorted((t.clip, t.left) for t in pairs) == sorted(
        (clip, c) for clip in ("s2", "s7") for c in "abc"
    )
    assert all(t.left == t.right and {t.expected, t.foreign} == {"left", "right"} for t in pairs)
    sides = Counter(t.foreign for t in pairs)
    assert abs(sides["left"] - sides["right"]) <= 1
    rendered = variant_stimuli(
        clips=["s2", "s7"], pairs=PAIRS, design="all_ordered", mismatched=True
    )
    assert {(t.clip, t.pair, "", t.foreign) for t in pairs} <= set(rendered)


def test_foreign_clip_is_the_next_one() -> None:
    assert [foreign_clip(["x", "y", "z"], c) for c in "xyz"] == ["y", "z", "x"]
