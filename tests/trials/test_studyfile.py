"""Study files: the example loads, every bad field gives one line naming file and field."""

from __future__ import annotations

import sys
import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.trials.design import ConditionPair
from app.trials.rules import ReplayPolicy
from app.trials.studyfile import load_study_file, loads_study, parse_study

StudyData = Callable[[], dict[str, Any]]
DESIGNS = "all_ordered, reference, unordered_counterbalanced, adaptive, rating, parallel"


def error_of(data: dict[str, Any], base_dir: Path) -> str:
    with pytest.raises(InputError) as caught:
        parse_study(data, source="study.toml", base_dir=base_dir)
    text = str(caught.value)
    assert "\n" not in text
    return text


def test_minimal_study_gets_the_documented_defaults(
    make_study_data: StudyData, study_dir: Path
) -> None:
    spec = parse_study(make_study_data(), source="study.toml", base_dir=study_dir)
    assert spec.design == "all_ordered" and spec.reference is None
    assert spec.condition_names == ["none", "random", "ground_truth"]
    assert [c.model for c in spec.conditions] == ["none", "random", "ground_truth"]
    assert spec.clips[0].audio == study_dir / "media" / "s2.wav"
    assert spec.clips[1].ground_truth == study_dir / "media" / "s7.fap"
    assert spec.undecided_allowed and spec.undecided_label == "Undecided"
    assert spec.replay == ReplayPolicy("unlimited")
    assert (spec.catch_trials, spec.catch_kind) == (0, "identical")
    assert spec.target_participants == 20 and spec.seed == 7
    assert spec.practice == ConditionPair("none", "ground_truth") and spec.practice_clip is None
    assert spec.block_by_clip and spec.redirect_url is None
    assert len(spec.pairs()) == 9 and spec.n_lists() == 2
    assert (spec.eyes, spec.normalize, dict(spec.render)) == ("generated", False, {})
    assert spec.posture == "shared"
    assert spec.rejoin == "resume"
    trials = spec.schedule(seed=1, list_index=1)
    assert len(trials) == 1 + 18 and trials[0].kind == "practice"


def test_the_example_study_file_loads(repo_root: Path) -> None:
    path = repo_root / "app" / "data" / "examples" / "study.toml"
    demo = repo_root / "app" / "data" / "demo"
    spec = load_study_file(path, check_files=(demo / "ground_truth.fap").is_file())
    assert spec.condition_names == ["none", "random", "speech_driven", "ground_truth"]
    assert spec.clips[0].audio == demo / "speech.wav"
    assert spec.clips[0].ground_truth == demo / "ground_truth.fap"
    assert spec.design == "all_ordered" and len(spec.pairs()) == 16
    assert spec.replay.kind == "play_to_end" and spec.undecided_label == "Cannot decide"
    assert spec.catch_trials == 2 and spec.redirect_url is not None
    assert spec.completion_code in spec.redirect_url


def test_paths_resolve_against_the_study_file_not_the_working_directory(
    study_text: str, study_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    nested = study_dir / "studies"
    nested.mkdir()
    text = study_text.replace('"media/', '"../media/')
    (nested / "study.toml").write_text(text, encoding="utf-8")
    monkeypatch.chdir(tmp_path / "media")
    spec = load_study_file(nested / "study.toml")
    assert spec.clips[0].audio == study_dir / "media" / "s2.wav"


def test_design_error_is_exactly_one_line_naming_file_and_field(
    make_study_data: StudyData, study_dir: Path
) -> None:
    data = make_study_data() | {"design": "foo"}
    assert error_of(data, study_dir) == f"study.toml: design: expected one of {DESIGNS}, got 'foo'"


def test_file_errors_name_the_file(study_text: str, study_dir: Path) -> None:
    path = study_dir / "study.toml"
    path.write_text('design = "foo"\n' + study_text, encoding="utf-8")
    with pytest.raises(InputError, match=f"^{path}: design: expected one of"):
        load_study_file(path)
    with pytest.raises(InputError, match="no such study file"):
        load_study_file(study_dir / "absent.toml")


def test_errors_come_in_the_order_of_the_documented_keys(study_dir: Path) -> None:
    assert error_of({}, study_dir) == "study.toml: title: missing (required)"
    assert error_of({"title": "t"}, study_dir) == "study.toml: question: missing (required)"
    data = {"title": "t", "question": "q", "design": "foo", "clips": 3}
    assert error_of(data, study_dir).startswith("study.toml: design: ")


def test_toml_syntax_errors_give_the_line(study_dir: Path) -> None:
    with pytest.raises(InputError) as caught:
        loads_study('title = "x"\nquestion = \n', source="s.toml", base_dir=study_dir)
    assert str(caught.value).startswith("s.toml:2: invalid TOML: ")


def set_path(data: dict[str, Any], dotted: str, value: Any) -> None:
    *parents, last = dotted.split(".")
    node: Any = data
    for key in parents:
        node = node[int(key)] if key.isdigit() else node.setdefault(key, {})
    index: Any = int(last) if last.isdigit() else last
    if value is DELETE:
        del node[index]
    else:
        node[index] = value


DELETE = object()
TWO_MODELS = [{"name": "none"}, {"name": "random"}]
BAD_FIELDS: list[tuple[dict[str, Any], str]] = [
    ({"title": DELETE}, "title: missing (required)"),
    ({"title": "  "}, "title: must not be empty"),
    ({"title": 42}, "title: expected a string, got 42"),
    ({"question": DELETE}, "question: missing (required)"),
    ({"instructions": ["a"]}, "instructions: expected a string, got an array"),
    ({"consent": 1.5}, "consent: expected a string, got 1.5"),
    ({"desing": "all_ordered"}, "desing: unknown key (expected one of title, question"),
    ({"design": "reference"}, "reference: missing (required by design = 'reference')"),
    (
        {"design": "reference", "reference": "best"},
        "reference: expected one of the conditions none, random, ground_truth, got 'best'",
    ),
    (
        {"reference": "none"},
        "reference: only applies to designs 'reference' and 'parallel', not 'all_ordered'",
    ),
    ({"seed": -1}, "seed: must be >= 0, got -1"),
    ({"seed": True}, "seed: expected an integer, got true"),
    ({"seed": 2**63}, "seed: must be <= 9223372036854775807, got 9223372036854775808"),
    ({"redirect_url": "https://x.org/a b"}, "redirect_url: expected an http:// or https:// URL"),
    ({"seed": "7"}, "seed: expected an integer, got '7'"),
    ({"target_participants": 0}, "target_participants: must be >= 1, got 0"),
    ({"completion_code": 123}, "completion_code: expected a string, got 123"),
    ({"redirect_url": "ftp://example.org"}, "redirect_url: expected an http:// or https:// URL"),
    ({"block_by_clip": "yes"}, "block_by_clip: expected true or false, got 'yes'"),
    ({"practice": ["none"]}, "practice: expected two condition names or false, got an array"),
    (
        {"practice": ["none", "zzz"]},
        "practice: expected condition names (none, random, ground_truth), got 'zzz'",
    ),
    ({"practice": True}, "practice: expected two condition names or false, got true"),
    ({"practice_clip": "s9"}, "practice_clip: expected one of the clips s2, s7, got 's9'"),
    ({"undecided": 3}, "undecided: expected a table, got 3"),
    ({"undecided.allowed": "no"}, "undecided.allowed: expected true or false, got 'no'"),
    ({"undecided.label": ""}, "undecided.label: must not be empty"),
    ({"undecided.text": "x"}, "undecided.text: unknown key (expected one of allowed, label)"),
    (
        {"replay.policy": "twice"},
        "replay.policy: expected one of unlimited, max_plays, play_to_end, got 'twice'",
    ),
    ({"replay.policy": "max_plays"}, "replay.max_plays: missing (required)"),
    ({"replay.policy": "max_plays", "replay.max_plays": 0}, "replay.max_plays: must be >= 1"),
    (
        {"replay.max_plays": 3},
        "replay.max_plays: only applies to policy = 'max_plays', not 'unlimited'",
    ),
    ({"catch.trials": -1}, "catch.trials: must be >= 0, got -1"),
    (
        {"catch.trials": 1, "catch.kind": "trick"},
        "catch.kind: expected one of identical, instructed, onscreen, got 'trick'",
    ),
    (
        {"catch.trials": 1, "undecided.allowed": False},
        "catch.kind: 'identical' catch trials expect the answer 'undecided'",
    ),
    ({"catch.trials": 19}, "catch.trials: 19 catch trials do not fit among the 18 trials"),
    ({"conditions": DELETE}, "conditions: missing (required)"),
    (
        {"conditions": {"name": "a"}},
        "conditions: expected an array of tables ([[conditions]]), got a table",
    ),
    ({"conditions.1": DELETE, "conditions.0": DELETE}, "conditions: needs at least two"),
    ({"conditions.1": "random"}, "conditions[1]: expected a table, got 'random'"),
    ({"conditions.1.name": DELETE}, "conditions[1].name: missing (required)"),
    ({"conditions.1.name": "my model"}, "conditions[1].name: expected a name of letters"),
    ({"conditions.1.name": "none"}, "conditions[1].name: repeats condition name 'none'"),
    ({"conditions.1.name": "mine"}, "conditions[1].model: missing: give a model (none, random"),
    (
        {"conditions.1.model": "gan"},
        "conditions[1].model: expected one of none, random, "
        "speech_driven, ground_truth, live_gmm, got 'gan'",
    ),
    ({"conditions.1.settings": 2}, "conditions[1].settings: expected a table, got 2"),
    (
        {"conditions.1.seed": 2},
        "conditions[1].seed: unknown key (expected one of name, model, settings, tracks, mesh)",
    ),
    (
        {
            "conditions.1.model": "random",
            "conditions.1.tracks": {"s2": "media/up_s2.fap", "s7": "media/up_s7.fap"},
        },
        "conditions[1].model: a condition has either uploaded tracks or a model, not both",
    ),
    (
        {"conditions.0": {"name": "mine", "tracks": {"s2": "media/up_s2.fap"}}},
        "conditions[0].tracks: no track for clip(s) s7",
    ),
    (
        {
            "conditions.0": {
                "name": "mine",
                "tracks": {
                    "s2": "media/up_s2.fap",
                    "s7": "media/up_s7.fap",
                    "s8": "media/up_s7.fap",
                },
            }
        },
        "conditions[0].tracks.s8: unknown key (expected one of s2, s7)",
    ),
    (
        {
            "conditions.0": {
                "name": "mine",
                "tracks": {"s2": "media/up_s2.fap", "s7": "media/x.fap"},
            }
        },
        "conditions[0].tracks.s7: no such file: ",
    ),
    (
        {
            "conditions.0": {
                "name": "mine",
                "tracks": {"s2": "media/x.txt", "s7": "media/up_s7.fap"},
            }
        },
        "conditions[0].tracks.s2: expected a .fap or .csv or .json or .bvh or .npy or .npz or "
        ".pkl file, got 'media/x.txt'",
    ),
    (
        {"clips.1.ground_truth": DELETE},
        "clips[1].ground_truth: missing (required by condition 'ground_truth', model "
        "'ground_truth')",
    ),
    ({"clips": DELETE}, "clips: missing (required)"),
    ({"clips": []}, "clips: needs at least one clip"),
    ({"clips.1.name": "s2"}, "clips[1].name: repeats clip name 's2'"),
    ({"clips.1.name": ".hidden"}, "clips[1].name: expected a name of letters"),
    ({"clips.0.audio": DELETE}, "clips[0].audio: missing (required)"),
    ({"clips.0.audio": "media/absent.wav"}, "clips[0].audio: no such file: "),
    ({"clips.0.audio": "media/x.txt"}, "clips[0].audio: expected a .wav or .flac or"),
    ({"clips.0.ground_truth": "media/s2.wav"}, "clips[0].ground_truth: expected a .fap or .csv"),
    ({"clips.0.ground_truth": ""}, "clips[0].ground_truth: must not be empty"),
    ({"eyes": "closed"}, "eyes: expected one of still, ground_truth, generated, own, got 'closed'"),
    ({"posture": "front"}, "posture: expected one of shared, per_condition, got 'front'"),
    ({"normalize": "yes"}, "normalize: expected true or false, got 'yes'"),
    (
        {"normalize": True, "clips.0.ground_truth": DELETE, "conditions": TWO_MODELS},
        "normalize: needs a ground_truth for every clip; missing for s2",
    ),
    (
        {"eyes": "ground_truth", "clips.0.ground_truth": DELETE, "conditions": TWO_MODELS},
        "eyes: needs a ground_truth for every clip; missing for s2",
    ),
    ({"render": {"size": "big"}}, "render.size: expected an integer"),
    (
        {"render": {"size": -3}},
        "render.size: expected a multiple of 16 of at least 64 pixels, got -3",
    ),
    ({"render": {"size": 100}}, "render.size: expected a multiple of 16 of at least 64 pixels"),
    ({"render": {"colour": 1}}, "render.colour: unknown key (expected one of size,"),
    ({"render": {"antialias": "fxaa"}}, "render.antialias: expected one of edges, msaa, none"),
    ({"render": {"look": "shiny"}}, "render.look: expected one of textured, plain"),
    ({"render": 3}, "render: expected a table, got 3"),
    ({"rejoin": "ask"}, "rejoin: expected one of resume, refuse, got 'ask'"),
    ({"rejoin": True}, "rejoin: expected a string, got true"),
    (
        {"clips.0.speaker": "x"},
        "clips[0].speaker: unknown key (expected one of name, audio, ground_truth)",
    ),
]


@pytest.mark.parametrize(
    ("changes", "expected"), BAD_FIELDS, ids=[",".join(c) for c, _ in BAD_FIELDS]
)
def test_each_bad_field_gives_one_line_naming_it(
    make_study_data: StudyData, study_dir: Path, changes: dict[str, Any], expected: str
) -> None:
    data = make_study_data()
    for dotted, value in changes.items():
        set_path(data, dotted, value)
    assert error_of(data, study_dir).startswith("study.toml: " + expected)


def test_missing_files_pass_when_not_checked(make_study_data: StudyData, tmp_path: Path) -> None:
    spec = parse_study(make_study_data(), source="study.toml", base_dir=tmp_path, check_files=False)
    assert spec.clips[0].audio == tmp_path / "media" / "s2.wav"


def test_uploaded_tracks_and_reference_design(make_study_data: StudyData, study_dir: Path) -> None:
    data = make_study_data() | {"design": "reference", "reference": "ground_truth"}
    data["conditions"].append(
        {"name": "mine", "tracks": {"s7": "media/up_s7.fap", "s2": "media/up_s2.fap"}}
    )
    spec = parse_study(data, source="study.toml", base_dir=study_dir)
    mine = spec.conditions[-1]
    assert mine.model is None and mine.tracks["s2"] == study_dir / "media" / "up_s2.fap"
    assert len(spec.pairs()) == 6 and spec.n_lists() == 4


def test_settings_are_checked_against_the_model_class(
    make_study_data: StudyData, study_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    class RandomCondition:
        def __init__(self, *, octaves: int = 6, seed_offset: int = 0) -> None: ...

    registry = types.ModuleType("app.stimuli.conditions")
    registry.condition_class = lambda name: RandomCondition  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "app.stimuli.conditions", registry)
    data = make_study_data()
    data["conditions"][1]["settings"] = {"octaves": 4}
    assert parse_study(data, base_dir=study_dir).conditions[1].settings == {"octaves": 4}
    data["conditions"][1]["settings"] = {"octave": 4}
    assert error_of(data, study_dir) == (
        "study.toml: conditions[1].settings: model 'random' "
        "takes octaves, seed_offset; unknown: octave"
    )


values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-5, 5)
    | st.integers()
    | st.floats(allow_nan=False)
    | st.text(max_size=5),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner, max_size=3)
    ),
    max_leaves=6,
)


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    key=st.sampled_from(
        [
            "title",
            "design",
            "reference",
            "seed",
            "practice",
            "undecided",
            "replay",
            "catch",
            "conditions",
            "clips",
            "redirect_url",
            "conditions.0",
            "clips.0",
            "clips.0.audio",
            "conditions.1.tracks",
            "replay.max_plays",
            "replay.policy",
            "catch.trials",
            "catch.kind",
            "practice_clip",
            "block_by_clip",
            "target_participants",
            "undecided.label",
            "undecided.allowed",
            "conditions.0.name",
            "conditions.0.model",
            "conditions.0.settings",
            "clips.1.name",
            "clips.0.ground_truth",
        ]
    ),
    value=values,
)
def test_junk_in_any_field_is_an_input_error_never_a_crash(
    make_study_data: StudyData, study_dir: Path, key: str, value: Any
) -> None:
    data = make_study_data()
    set_path(data, key, value)
    try:
        parse_study(data, base_dir=study_dir)
    except InputError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("study.toml: ")


def test_uploaded_study_files_cannot_reach_outside_their_folder(
    study_text: str, study_dir: Path
) -> None:
    upload = study_dir / "upload"
    upload.mkdir()
    with pytest.raises(InputError, match=r"^up\.toml: clips\[0\]\.audio: must be a path inside"):
        loads_study(
            study_text.replace('"media/', '"../media/'),
            source="up.toml",
            base_dir=upload,
            confine=True,
        )
    spec = loads_study(study_text, source="up.toml", base_dir=study_dir, confine=True)
    assert spec.clips[0].audio == study_dir / "media" / "s2.wav"


def test_settings_are_checked_against_the_installed_registry(
    make_study_data: StudyData, study_dir: Path
) -> None:
    registry = pytest.importorskip("app.stimuli.conditions")
    try:
        registry.condition_class("random")
    except InputError:
        pytest.skip("the random condition is not installed")
    data = make_study_data()
    data["conditions"][1]["settings"] = {"no_such_setting": 1}
    assert error_of(data, study_dir).startswith(
        "study.toml: conditions[1].settings: model 'random' takes "
    )


def test_stimulus_settings_are_read_and_round_trip(
    make_study_data: StudyData, study_dir: Path
) -> None:
    data = make_study_data()
    data.update(
        eyes="generated", normalize=True, render={"size": 256, "antialias": "msaa", "look": "plain"}
    )
    data["clips"][0]["ground_truth"] = data["clips"][1]["ground_truth"]
    spec = parse_study(data, source="study.toml", base_dir=study_dir)
    assert (spec.eyes, spec.normalize) == ("generated", True)
    assert dict(spec.render) == {"size": 256, "antialias": "msaa", "look": "plain"}
    again = parse_study(spec.to_dict(), source="study.toml", base_dir=study_dir)
    assert (again.eyes, again.normalize, dict(again.render)) == ("generated", True, spec.render)
    assert "posture" not in spec.to_dict()  # the default is not written


def test_the_thesis_per_condition_posture_is_a_study_setting(
    make_study_data: StudyData, study_dir: Path
) -> None:
    data = make_study_data()
    data.update(posture="per_condition", eyes="still")
    spec = parse_study(data, source="study.toml", base_dir=study_dir)
    assert (spec.posture, spec.eyes) == ("per_condition", "still")
    again = parse_study(spec.to_dict(), source="study.toml", base_dir=study_dir)
    assert again.posture == "per_condition"


def test_the_rejoin_policy_is_read_and_round_trips(
    make_study_data: StudyData, study_dir: Path
) -> None:
    data = make_study_data()
    data["rejoin"] = "refuse"
    spec = parse_study(data, source="study.toml", base_dir=study_dir)
    assert spec.rejoin == "refuse"
    assert loads_study(spec.to_toml(), base_dir=study_dir).rejoin == "refuse"


def test_an_adaptive_design_needs_eight_conditions(
    make_study_data: StudyData, study_dir: Path
) -> None:
    data = make_study_data() | {"design": "adaptive"}
    assert error_of(data, study_dir) == (
        "study.toml: design: 'adaptive' needs at least 8 conditions, the study has "
        f"{len(data['conditions'])}"
    )
