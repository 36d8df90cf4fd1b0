"""``facepair leaderboard`` (``app.commands.leaderboard``): a bad season file and a refused
submission end in one line per problem and exit code 2; a passing one prints its preview link."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from app.cli import main
from app.leaderboard.demo import write_benchmark, write_systems

ORGANISER = "org@example.org"


@pytest.fixture
def season(tmp_path, monkeypatch) -> tuple[Path, dict[str, list[Path]]]:
    """The demo season in a fresh SQLite file the commands use (its renders not run)."""
    from flask_migrate import upgrade

    from app.commands import leaderboard as commands
    from app.commands.webapp import app_context, offline_app
    from app.leaderboard.season import load_season_file
    from app.web.board.seasons import create_season
    from app.web.extensions import db
    from app.web.infra.accounts import create_user

    monkeypatch.setenv("FACEPAIR_INSTANCE", str(tmp_path / "instance"))
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'facepair.sqlite'}")
    monkeypatch.setenv("MEDIA_ROOT", str(tmp_path / "media"))
    monkeypatch.setattr(commands, "run_jobs", lambda jobs: None)
    season_file = write_benchmark(tmp_path / "bench", organiser=ORGANISER)
    with app_context(offline_app()):
        upgrade()
        create_user(ORGANISER, "correct horse battery staple")
        create_season(load_season_file(season_file), season_file.read_text())
        db.session.commit()
    return season_file, write_systems(tmp_path / "bench", tmp_path / "systems")


def test_a_bad_season_file_is_one_line_and_exit_2(tmp_path) -> None:
    season_file = write_benchmark(tmp_path / "bench", organiser=ORGANISER)
    text = season_file.read_text().replace('eyes = "generated"', 'eyes = "sideways"')
    season_file.write_text(text)
    result = CliRunner().invoke(main, ["leaderboard", "season", "create", str(season_file)])
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "test.eyes" in lines[0] and "season.toml" in lines[0]


def test_submit_lists_every_problem_then_passes(season) -> None:
    _, systems = season
    runner = CliRunner()
    base = ["leaderboard", "submit", "demo", "--system", "Prosody", "--team", "T"]
    refused = runner.invoke(main, [*base, str(systems["ProsodyARX"][0]), "--contact", "x"])
    assert refused.exit_code == 2
    lines = refused.output.splitlines()
    assert all(line.startswith("facepair: error: ") for line in lines)
    said = "\n".join(lines)
    assert "contact:" in said and "licence:" in said and "training_data:" in said
    assert "s02: no track for this segment" in said
    passed = runner.invoke(
        main,
        [
            *base,
            *map(str, systems["ProsodyARX"]),
            "--contact",
            "t@example.org",
            "--training-data",
            "ours",
            "--grant-licence",
        ],
    )
    assert passed.exit_code == 0, passed.output
    assert "passed its checks" in passed.output
    assert "private preview: /leaderboard/demo/preview/" in passed.output
    status = runner.invoke(main, ["leaderboard", "status", "demo"])
    assert "previewing" in status.output and "Prosody" in status.output
    early = runner.invoke(main, ["leaderboard", "queue", "demo", "Prosody"])
    assert early.exit_code == 2 and "only a rendered preview can be queued" in early.output
    none = runner.invoke(main, ["leaderboard", "round", "create", "demo"])
    assert none.exit_code == 2 and "no system is queued" in none.output
