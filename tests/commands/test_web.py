import secrets

import sqlalchemy as sa
from click.testing import CliRunner

from app.cli import main
from app.web.extensions import db
from app.web.models import Study
from tests.support.cli import cli_env


def _study_file(tmp_path, web, **toml):
    web.write_wav(tmp_path / "s1.wav")
    path = tmp_path / "study.toml"
    path.write_text(web.toml(**toml))
    return path


def test_experimenter_add_and_study_create(app, monkeypatch, tmp_path, web):
    cli_env(monkeypatch, app)
    runner = CliRunner()
    added = runner.invoke(
        main,
        ["experimenter", "add", "Lab@Example.org"],
        input="long enough passphrase\nlong enough passphrase\n",
    )
    assert added.exit_code == 0, added.output
    short = runner.invoke(main, ["experimenter", "add", "x@example.org", "--password", "short"])
    assert short.exit_code == 2 and "password: at least 12 characters" in short.output
    path = _study_file(tmp_path, web)
    created = runner.invoke(main, ["study", "create", str(path), "--owner", "lab@example.org"])
    assert created.exit_code == 0, created.output
    assert "participant link: /s/" in created.output
    with app.app_context():
        study = db.session.scalar(sa.select(Study))
        assert (study.title, study.owner.email, study.status) == (
            "Test study",
            "lab@example.org",
            "draft",
        )


def test_study_create_errors_are_one_line(app, monkeypatch, tmp_path, web):
    cli_env(monkeypatch, app)
    path = _study_file(tmp_path, web)
    unknown = CliRunner().invoke(main, ["study", "create", str(path), "--owner", "no@x.org"])
    assert unknown.exit_code == 2 and "--owner: no experimenter" in unknown.output
    web.user()
    bad = tmp_path / "bad.toml"
    bad.write_text(web.toml(design="zigzag"))
    result = CliRunner().invoke(main, ["study", "create", str(bad), "--owner", "exp@example.org"])
    assert result.exit_code == 2
    assert result.output.strip().endswith(
        "expected one of all_ordered, reference, unordered_counterbalanced, adaptive, rating, "
        "parallel, got 'zigzag'"
    )
    assert "Traceback" not in result.output


def test_serve_refuses_to_start_without_a_real_key(monkeypatch, tmp_path):
    from app.commands import web as commands

    started = []
    monkeypatch.setattr(commands, "serve_app", lambda *args: started.append(args))
    monkeypatch.setenv("FACEPAIR_INSTANCE", str(tmp_path))
    for key in (None, "dev-only-change-me", "a-long-random-deployment-key"):
        if key is None:
            monkeypatch.delenv("SECRET_KEY", raising=False)
        else:
            monkeypatch.setenv("SECRET_KEY", key)
        result = CliRunner().invoke(main, ["serve"])
        assert result.exit_code == 2 and started == []
        assert result.output.startswith("facepair: error: SECRET_KEY: ")
        assert result.output.count("\n") == 1 and "Traceback" not in result.output
    monkeypatch.setenv("SECRET_KEY", secrets.token_hex(32))
    assert CliRunner().invoke(main, ["serve"]).exit_code == 0 and len(started) == 1


def test_the_shipped_example_creates_a_study(app, monkeypatch, web, repo_root):
    """The same app/data/examples/study.toml the web takes as an upload (tests/web/experimenter)."""
    cli_env(monkeypatch, app)
    web.user("lab@example.org")
    created = CliRunner().invoke(
        main,
        [
            "study",
            "create",
            str(repo_root / "app" / "data" / "examples" / "study.toml"),
            "--owner",
            "lab@example.org",
        ],
    )
    assert created.exit_code == 0, created.output
    with app.app_context():
        study = db.session.scalar(sa.select(Study))
        assert study.title == "Head and eyebrow motion of a talking face"
        assert study.settings["auto_exclude"] == [
            "catch_failed",
            "unfinished",
            "audio_check_failed",
        ]
