"""The trials package stays pure: importing all of it loads neither Flask nor SQLAlchemy."""

from __future__ import annotations

import subprocess
import sys

from app.trials import (
    assignment,
    catch,
    counterbalance,
    design,
    fields,
    rules,
    schedule,
    stimuli,
    studyfile,
    studyspec,
    trial,
)

MODULES = (
    assignment,
    catch,
    counterbalance,
    design,
    fields,
    rules,
    schedule,
    stimuli,
    studyfile,
    studyspec,
    trial,
)


def test_importing_the_package_loads_no_web_framework(repo_root: object) -> None:
    names = ", ".join(m.__name__ for m in MODULES)
    code = (
        f"import sys, importlib\n"
        f"for name in '{names}'.split(', '): importlib.import_module(name)\n"
        f"bad = [m for m in ('flask', 'sqlalchemy', 'moderngl') if m in sys.modules]\n"
        f"assert not bad, bad\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=str(repo_root), capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr


def test_every_module_has_a_docstring_citing_what_it_implements() -> None:
    for module in MODULES:
        assert module.__doc__ and len(module.__doc__.strip()) > 80, module.__name__
