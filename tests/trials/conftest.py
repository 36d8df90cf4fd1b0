"""Fixtures of the trials tests: a small valid study (thesis-like: three conditions, two
segments) with empty media files in a temporary folder."""

from __future__ import annotations

import copy
import sys
import tomllib
import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

BASE = """
title = "Head motion"
question = "Which animation do you consider to be more realistic motion-wise?"
seed = 7

[[conditions]]
name = "none"

[[conditions]]
name = "random"

[[conditions]]
name = "ground_truth"

[[clips]]
name = "s2"
audio = "media/s2.wav"
ground_truth = "media/s2.fap"

[[clips]]
name = "s7"
audio = "media/s7.wav"
ground_truth = "media/s7.fap"
"""


@pytest.fixture
def study_dir(tmp_path: Path) -> Path:
    media = tmp_path / "media"
    media.mkdir()
    for name in ("s2.wav", "s7.wav", "s2.fap", "s7.fap", "up_s2.fap", "up_s7.fap", "x.txt"):
        (media / name).write_bytes(b"")
    return tmp_path


@pytest.fixture
def make_study_data() -> Callable[[], dict[str, Any]]:
    """A factory of fresh mappings of the valid study :data:`BASE`, to be changed by a test."""
    return lambda: copy.deepcopy(tomllib.loads(BASE))


@pytest.fixture
def study_text() -> str:
    """The valid study :data:`BASE` as TOML text."""
    return BASE


@pytest.fixture
def any_settings(monkeypatch: pytest.MonkeyPatch) -> None:
    """A stand-in condition registry whose models take any settings, so tests of the file
    format do not depend on the stimulus engine's parameter names."""

    class AnyCondition:
        def __init__(self, **settings: Any) -> None: ...

    registry = types.ModuleType("app.stimuli.conditions")
    registry.condition_class = lambda name: AnyCondition  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "app.stimuli.conditions", registry)
