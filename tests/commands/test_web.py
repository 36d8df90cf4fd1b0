import shutil

import click
import pytest
import sqlalchemy as sa
from click.testing import CliRunner
from flask_migrate import upgrade

from app.cli import main
from app.web.extensions import db
from app.web.models import Job, Stimulus, Study, User


def _env(monkeypatch, app):
    monkeypatch.setenv("DATABASE_URL", app.config["SQLALCHEMY_DATABASE_URI"])
    monkeypatch.setenv("MEDIA_ROOT", app.config["MEDIA_ROOT"])


def _study_file(tmp_path, web, **toml):
    web.write_wav(tmp_path / "s1.wav")
    path = tmp_path / "study.toml"
    path.write_text(web.toml(**toml))
    return path


def test_experimenter_add_and_study_create(app, monkeypatch, tmp_path, web):
    _env(monkeypatch, app)
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
    _env(monkeypatch, app)
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
    monkeypatch.setattr(commands, "_serve", lambda *args: started.append(args))
    monkeypatch.setenv("FACEPAIR_INSTANCE", str(tmp_path))
    for key in (None, "dev-only-change-me"):
        if key is None:
            monkeypatch.delenv("SECRET_KEY", raising=False)
        else:
            monkeypatch.setenv("SECRET_KEY", key)
        result = CliRunner().invoke(main, ["serve"])
        assert result.exit_code == 2 and started == []
        assert result.output.startswith("facepair: error: SECRET_KEY: ")
        assert result.output.count("\n") == 1 and "Traceback" not in result.output
    monkeypatch.setenv("SECRET_KEY", "a-long-random-deployment-key")
    assert CliRunner().invoke(main, ["serve"]).exit_code == 0 and len(started) == 1


def test_demo_refuses_any_other_database(app, monkeypatch, tmp_path):
    """The demo writes a publicly known login: never into a database named by DATABASE_URL."""
    monkeypatch.setenv("FACEPAIR_INSTANCE", str(tmp_path / "instance"))
    _env(monkeypatch, app)
    result = CliRunner().invoke(main, ["demo", "--no-serve"])
    assert result.exit_code == 2 and "DATABASE_URL: the demo runs only on" in result.output
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(User.id))) == 0


def test_demo_sets_up_a_ready_study(monkeypatch, tmp_path, web):
    """The demo's wiring on its embedded SQLite file, with generation and rendering stubbed
    (the pipeline is tested on its own); the study file is the repository's example."""
    from app.web import create_app
    from app.web.jobs import tasks

    instance = tmp_path / "instance"
    monkeypatch.setenv("FACEPAIR_INSTANCE", str(instance))
    for name in ("DATABASE_URL", "SECRET_KEY", "MEDIA_ROOT"):
        monkeypatch.delenv(name, raising=False)

    def fake_generate(study, progress):
        progress(1, 1)
        return "stub"

    def fake_render(study, progress):
        from app.web.infra.storage import media_dir

        for stimulus in db.session.scalars(
            sa.select(Stimulus).where(Stimulus.study_id == study.id)
        ):
            stimulus.video_path = f"videos/{stimulus.id}.mp4"
            (media_dir(study) / "videos").mkdir(exist_ok=True)
            shutil.copyfile(web.tiny_video, media_dir(study) / stimulus.video_path)
        db.session.commit()
        return "stub"

    monkeypatch.setitem(tasks.TASKS, "generate", fake_generate)
    monkeypatch.setitem(tasks.TASKS, "render", fake_render)
    from app.commands import web as commands

    apart = []

    def run_here(app, study_id, kinds):
        # The stubs above live in this process; the real thing spawns a fresh one.
        apart.append(kinds)
        commands._run_jobs(study_id, kinds)

    monkeypatch.setattr(commands, "_run_jobs_apart", run_here)
    path = _study_file(tmp_path, web, design="all_ordered")
    result = CliRunner().invoke(
        main, ["demo", "--no-serve", "--port", "5077", "--study-file", str(path)]
    )
    assert result.exit_code == 0, result.output
    assert "participant:   http://127.0.0.1:5077/s/" in result.output
    assert "login:         demo@example.org / facepair-demo" in result.output
    assert apart == [("generate", "render")]  # never rendered in the serving process
    key = (instance / "secret_key").read_text().strip()
    assert len(key) >= 32 and (instance / "secret_key").stat().st_mode & 0o077 == 0
    app = create_app({"TESTING": True})
    assert app.config["SQLALCHEMY_DATABASE_URI"].endswith("instance/facepair.sqlite")
    with app.app_context():
        user = db.session.scalar(sa.select(User).where(User.email == "demo@example.org"))
        assert user.check_password("facepair-demo")
        study = db.session.scalar(sa.select(Study))
        assert study.status == "open" and study.slug in result.output
    # Running it again reuses the open demo study.
    again = CliRunner().invoke(main, ["demo", "--no-serve", "--study-file", str(path)])
    assert again.exit_code == 0 and study.slug in again.output
    assert (instance / "secret_key").read_text().strip() == key
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Study.id))) == 1
        db.engine.dispose()


def test_demo_jobs_run_in_a_spawned_process(monkeypatch, tmp_path, web):
    """The demo's jobs run apart from the process that will serve: a failing job there is
    reported from the child (here: render before the tracks exist)."""
    from app.commands.web import _run_jobs_apart
    from app.trials.studyfile import load_study_file
    from app.web import create_app
    from app.web.infra.accounts import create_user
    from app.web.study.studies import create_study

    monkeypatch.setenv("FACEPAIR_INSTANCE", str(tmp_path / "instance"))
    for name in ("DATABASE_URL", "SECRET_KEY", "MEDIA_ROOT"):
        monkeypatch.delenv(name, raising=False)
    app = create_app({"TESTING": True})
    with app.app_context():
        upgrade()
        user = create_user("demo-test@example.org", "long enough pw")
        db.session.flush()
        study = create_study(user, load_study_file(_study_file(tmp_path, web)))
        db.session.commit()
        with pytest.raises(click.ClickException, match="render of study"):
            _run_jobs_apart(app, study.id, ("render",))
        job = db.session.scalar(sa.select(Job))
        assert job.status == "failed" and "generate the tracks first" in job.message
        db.session.remove()
        db.engine.dispose()


def test_the_shipped_example_creates_a_study(app, monkeypatch, web, repo_root):
    """The same app/data/examples/study.toml the web takes as an upload (tests/experimenter)."""
    _env(monkeypatch, app)
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
