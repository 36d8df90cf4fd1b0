"""Every example in a docstring of app/ and renderer/ runs as written (``>>>`` lines are
claims: a wrong one fails here, whichever module holds it)."""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
#: Alembic's revision scripts import their context only when Alembic runs them.
SKIPPED = ("app/web/migrations/",)


def _modules_with_examples() -> list[str]:
    names = []
    for package in ("app", "renderer"):
        for path in sorted((ROOT / package).rglob("*.py")):
            relative = path.relative_to(ROOT).as_posix()
            if relative.startswith(SKIPPED) or ">>>" not in path.read_text(encoding="utf-8"):
                continue
            module = relative[: -len(".py")].replace("/", ".")
            names.append(module.removesuffix(".__init__"))
    return names


MODULES = _modules_with_examples()


def test_the_examples_are_found():
    # a search that found nothing would pass every module below by having none
    assert len(MODULES) > 100
    assert "renderer.mouthregion" in MODULES and "app.stimuli.live.condition" in MODULES


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples in {name} failed"
