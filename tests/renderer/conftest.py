"""Fixtures of the renderer tests: the built-in head exported as a glTF avatar."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def exported_head(tmp_path_factory) -> Path:
    """The built-in head exported as a glTF avatar (``facepair face export``)."""
    from renderer.faceexport import export_builtin_head

    return export_builtin_head(tmp_path_factory.mktemp("avatar") / "head.glb")
