"""The wheel works outside the repository.

Builds the wheel, checks it ships the package data (front end, templates, migrations, demo
speech and study, default models), installs it into a fresh virtual environment and, from a
folder outside the checkout, runs ``facepair demo --no-serve`` (migrate, demo login, generate,
render), ``facepair stimuli generate`` on the default models and ``facepair analyze``.

The dependencies come from uv's cache once downloaded; the module takes under a minute on two
cores, most of it the demo rendering its clips (at a reduced size and rate).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

from app.trials.participation import LANGUAGES

REPO = Path(__file__).resolve().parent.parent
#: Files the installed package reads at run time; each must be in the wheel.
PACKAGE_DATA = (
    "app/web/static/participant.js",
    "app/web/static/style.css",
    "app/web/templates/base.html",
    # The participant pages' catalogues, compiled by the app when first needed.
    *(f"app/web/translations/{lang}/LC_MESSAGES/messages.po" for lang in LANGUAGES),
    "app/web/migrations/env.py",
    "app/web/migrations/alembic.ini",
    "app/web/migrations/script.py.mako",
    "app/web/migrations/versions/0001_initial_schema.py",
    "app/data/demo/speech.wav",
    "app/data/demo/ground_truth.fap",
    "app/data/demo/COPYING.cmu_arctic",
    "app/data/examples/study.toml",
    # the study-file reference the New-study page links (pyproject.toml's force-include)
    "app/data/docs/studyfile.md",
    "app/data/examples/votes.csv",
    "app/data/models/head_arx_default.json",
    "app/data/models/live_gmm_default.npz",
)
#: Settings of the checkout's test run that must not reach the installed copy.
LEAKS = (
    "PYTHONPATH",
    "DATABASE_URL",
    "SECRET_KEY",
    "MEDIA_ROOT",
    "REDIS_URL",
    "FLASK_APP",
    "FACEPAIR_INSTANCE",
    "VIRTUAL_ENV",
)

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    dist = tmp_path_factory.mktemp("dist")
    _run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(dist), str(REPO)],
        dict(os.environ),
        dist,
    )
    (built,) = dist.glob("facepair-*.whl")
    return built


@pytest.fixture(scope="module")
def installed(wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """A fresh venv holding the wheel; returns the environment to run its ``facepair`` in."""
    root = tmp_path_factory.mktemp("installed")
    # uv (a test dependency) links the dependencies from its cache: seconds, where pip
    # unpacks numpy, scipy, pandas and matplotlib again for a minute and a half.
    uv = [sys.executable, "-m", "uv", "--quiet"]
    _run([*uv, "venv", "--python", sys.executable, str(root / "venv")], dict(os.environ), root)
    _run(
        [*uv, "pip", "install", "--python", str(root / "venv" / "bin" / "python"), str(wheel)],
        dict(os.environ),
        root,
    )
    env = {k: v for k, v in os.environ.items() if k not in LEAKS}
    # An installed package has its bytecode: pip compiles it at install, Python writes it on a
    # first import. uv links the libraries uncompiled, so where the host forbids writing
    # bytecode every command here compiled numpy, scipy, pandas and matplotlib again (4.5 s
    # of CPU a process): the first command now writes it.
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env["PATH"] = f"{root / 'venv' / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    return env


def _run(args: list[str], env: dict[str, str], cwd: Path) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(args, env=env, cwd=cwd, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"{' '.join(args)}: {result.stdout}\n{result.stderr}"
    return result


def test_the_wheel_ships_the_package_data_and_nothing_of_the_checkout(wheel: Path) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = [name for name in PACKAGE_DATA if name not in names]
    assert not missing, missing
    tops = {name.split("/", 1)[0] for name in names if not name.startswith("facepair-")}
    assert tops == {"app", "renderer"}
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")]
    # The demo speech is the short clip (4 s); the whole wheel stays small.
    assert wheel.stat().st_size < 2_000_000


def test_the_dockerfile_installs_the_wheel_not_the_source_tree() -> None:
    dockerfile = (REPO / "Dockerfile").read_text(encoding="utf-8")
    final = dockerfile.rsplit("\nFROM ", 1)[1]
    assert "--wheel" in dockerfile.split("\nFROM ", 2)[1]
    assert "COPY . ." not in final and ".whl" in final


def test_the_installed_package_imports_from_the_venv_with_its_version(
    installed: dict[str, str], tmp_path: Path
) -> None:
    code = "import app, app.data; print(app.__file__); print(app.__version__)"
    where, version = _run(["python", "-c", code], installed, tmp_path).stdout.split()
    assert "site-packages" in where and not Path(where).is_relative_to(REPO)
    with open(REPO / "pyproject.toml", "rb") as f:
        assert version == tomllib.load(f)["project"]["version"]


def test_demo_migrates_generates_renders_and_exits(
    installed: dict[str, str], tmp_path: Path
) -> None:
    env = {**installed, "FACEPAIR_INSTANCE": str(tmp_path / "instance")}
    # The shipped example study as the demo reads it, its clips rendered at 192 px and 10
    # frames a second: what is checked is that the installed package renders them all, and
    # the full size costs a minute here (the renderer's tests and benchmark cover it).
    example = _run(
        ["python", "-c", "from app.data import data_path; print(data_path('examples'))"],
        installed,
        tmp_path,
    ).stdout.strip()
    study = (Path(example) / "study.toml").read_text(encoding="utf-8")
    study = study.replace('"../demo/', f'"{Path(example).parent / "demo"}/')
    (tmp_path / "demo.toml").write_text(
        study.replace("\n[undecided]", "\n[render]\nsize = 192\nfps = 10\n\n[undecided]", 1),
        encoding="utf-8",
    )
    assert "[render]" in (tmp_path / "demo.toml").read_text(encoding="utf-8")
    demo = ["facepair", "demo", "--no-serve", "--study-file", str(tmp_path / "demo.toml")]
    out = _run(demo, env, tmp_path).stdout
    assert "/s/" in out and "login:" in out
    assert (tmp_path / "instance" / "facepair.sqlite").stat().st_size > 0
    clips = list((tmp_path / "instance" / "media").rglob("*.mp4"))
    assert len(clips) >= 12, clips  # 4 conditions in all ordered pairs, at least
    assert all(clip.stat().st_size > 1000 for clip in clips)
    # A second run finds the open study and renders nothing again.
    again = _run(demo, env, tmp_path)
    assert "creating the demo study" not in again.stderr


def test_stimuli_generate_uses_the_shipped_default_models(
    installed: dict[str, str], tmp_path: Path
) -> None:
    speech = _run(
        ["python", "-c", "from app.data import data_path; print(data_path('demo', 'speech.wav'))"],
        installed,
        tmp_path,
    ).stdout.strip()
    assert not Path(speech).is_relative_to(REPO)
    _run(
        [
            "facepair",
            "stimuli",
            "generate",
            "--audio",
            speech,
            "--conditions",
            "none,random,speech_driven,live_gmm",
            "--out",
            "gen",
            "--no-plot",
        ],
        installed,
        tmp_path,
    )
    for name in ("none", "random", "speech_driven", "live_gmm"):
        assert (tmp_path / "gen" / f"{name}.fap").stat().st_size > 1000, name
    summary = (tmp_path / "gen" / "summary.json").read_text(encoding="utf-8")
    assert "head_arx_default.json" in summary and "live_gmm_default.npz" in summary


def test_analyze_reads_votes_and_writes_the_report(
    installed: dict[str, str], tmp_path: Path
) -> None:
    _run(["python", "-m", "app.analysis.example", "votes.csv"], installed, tmp_path)
    _run(
        [
            "facepair",
            "analyze",
            "votes.csv",
            "--json",
            "out.json",
            "--report",
            "report.html",
            "--bootstrap",
            "100",
        ],
        installed,
        tmp_path,
    )
    result = json.loads((tmp_path / "out.json").read_text(encoding="utf-8"))
    assert result and (tmp_path / "report.html").stat().st_size > 1000
