"""Study specs: derived design quantities, the dict/TOML writers and their round trip."""

from __future__ import annotations

import doctest
import importlib.util
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.trials import studyspec
from app.trials.design import ConditionPair
from app.trials.studyfile import loads_study, parse_study
from app.trials.studyspec import KNOWN_MODELS, MODELS, dump_toml

StudyData = Callable[[], dict[str, Any]]


def test_docstring_examples() -> None:
    assert doctest.testmod(studyspec).failed == 0


def test_models_are_those_of_the_condition_registry() -> None:
    if importlib.util.find_spec("app.stimuli.conditions") is None:
        assert MODELS == KNOWN_MODELS
        return
    from app.stimuli.conditions import CONDITIONS

    assert MODELS == tuple(CONDITIONS)
    assert set(KNOWN_MODELS) <= set(CONDITIONS)


def test_derived_design_quantities(make_study_data: StudyData, study_dir: Path) -> None:
    data = make_study_data() | {
        "design": "reference",
        "reference": "ground_truth",
        "practice_clip": "s7",
        "catch": {"trials": 2},
    }
    spec = parse_study(data, base_dir=study_dir)
    assert spec.clip_names == ["s2", "s7"]
    assert spec.pairs() == [
        ConditionPair("none", "ground_truth"),
        ConditionPair("ground_truth", "none"),
        ConditionPair("random", "ground_truth"),
        ConditionPair("ground_truth", "random"),
    ]
    assert spec.n_lists() == 4
    trials = spec.schedule(seed=3, list_index=2)
    assert len(trials) == 1 + 2 * 2 + 2
    assert trials[0].pair == ConditionPair("none", "ground_truth") and trials[0].clip == "s7"
    assert trials == spec.schedule(seed=3, list_index=2)
    stimuli = spec.stimuli()
    assert ("s7", ConditionPair("none", "ground_truth")) in stimuli
    assert ("s2", ConditionPair("random", "random")) in stimuli  # identical catch trials
    assert len(stimuli) == 2 * 4 + 2 * 3
    assert all(
        (t.clip, t.pair) in stimuli for k in range(4) for t in spec.schedule(seed=k, list_index=k)
    )


def test_dump_toml_quotes_what_toml_needs() -> None:
    text = dump_toml(
        {"a b": 'x"y\n\x7f', "n": -3, "f": float("inf"), "t": [True, 1.5], "s": {"k": {"deep": []}}}
    )
    assert text == (
        '"a b" = "x\\"y\\n\\u007f"\nn = -3\nf = inf\nt = [true, 1.5]\n\n[s]\nk = {deep = []}\n'
    )


def test_spec_round_trips_through_dict_and_toml(
    any_settings: None, make_study_data: StudyData, study_dir: Path
) -> None:
    data = make_study_data() | {
        "design": "unordered_counterbalanced",
        "redirect_url": "https://x.org/?a=1",
        "replay": {"policy": "max_plays", "max_plays": 3},
        "catch": {"trials": 2, "kind": "instructed"},
        "practice": False,
    }
    data["conditions"][0]["settings"] = {
        "scale": 0.5,
        "octaves": [1, 2],
        "on": True,
        "nested": {"k": "v"},
    }
    spec = parse_study(data, base_dir=study_dir)
    assert parse_study(spec.to_dict(), base_dir=study_dir) == spec
    assert loads_study(spec.to_toml(), base_dir=study_dir) == spec


texts = st.text(st.characters(exclude_categories=("Cs",)), max_size=40)


@settings(
    max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    title=texts.filter(str.strip),
    instructions=texts,
    label=texts.filter(str.strip),
    code=texts,
    seed=st.integers(0, 2**63 - 1),
    scale=st.floats(allow_nan=False),
)
def test_any_text_survives_the_toml_round_trip(
    any_settings: None,
    make_study_data: StudyData,
    study_dir: Path,
    title: str,
    instructions: str,
    label: str,
    code: str,
    seed: int,
    scale: float,
) -> None:
    data = make_study_data() | {
        "title": title,
        "instructions": instructions,
        "completion_code": code,
        "seed": seed,
        "undecided": {"label": label},
    }
    data["conditions"][1]["settings"] = {"scale": scale}
    spec = parse_study(data, base_dir=study_dir)
    assert loads_study(spec.to_toml(), base_dir=study_dir) == spec
