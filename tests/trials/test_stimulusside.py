"""The stimulus side of a study file: clips, conditions, stimulus and render settings
(``app.trials.stimulusside``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.errors import InputError
from app.trials.stimulusside import StimulusSideReader


def _reader(study_dir: Path) -> StimulusSideReader:
    return StimulusSideReader("study.toml", study_dir)


def test_the_render_choices_repeat_the_renderers() -> None:
    # repeated so that reading a study file imports no GL: the copies must agree
    from app.trials import stimulusside
    from renderer.gl import ANTIALIAS_MODES
    from renderer.headmodel import LOOKS

    assert stimulusside.ANTIALIAS_MODES == ANTIALIAS_MODES
    assert stimulusside.LOOKS == LOOKS


def test_clips_and_conditions_are_read_in_order(study_dir: Path, make_study_data) -> None:
    reader = _reader(study_dir)
    top = make_study_data()
    clips = reader.clips(top)
    assert [c.name for c in clips] == ["s2", "s7"]
    assert clips[0].ground_truth is not None
    conditions = reader.conditions(top, clips)
    assert [(c.name, c.model) for c in conditions] == [
        ("none", "none"),
        ("random", "random"),
        ("ground_truth", "ground_truth"),
    ]


def test_uploaded_tracks_need_one_for_every_clip(study_dir: Path, make_study_data) -> None:
    reader = _reader(study_dir)
    top = make_study_data()
    top["conditions"][1] = {"name": "up", "tracks": {"s2": "media/up_s2.fap"}}
    with pytest.raises(InputError, match=r"conditions\[1\]\.tracks: no track for clip\(s\) s7"):
        reader.conditions(top, reader.clips(top))


def test_stimulus_settings_default_and_refuse_a_face_size(study_dir: Path, make_study_data) -> None:
    reader = _reader(study_dir)
    top = make_study_data()
    settings = reader.stimulus_settings(top, reader.clips(top))
    assert settings["render"] == {} and settings["lips"] is None and settings["pad"] is False
    assert set(settings) == {
        "eyes",
        "normalize",
        "render",
        "posture",
        "lips",
        "pad",
        "brows",
        "meshes",
        "mesh_eyes",
    }
    top["render"] = {"size": 100}
    with pytest.raises(InputError, match="render.size: expected a multiple of 16"):
        reader.stimulus_settings(top, reader.clips(top))
