"""``facepair demo`` (``app.commands.demo``): a ready study on the embedded SQLite file, and a
greeting of links, the login and the log file, everything else in that log."""

import shutil

import click
import pytest
import sqlalchemy as sa
from click.testing import CliRunner
from flask_migrate import upgrade

from app.cli import main
from app.web.extensions import db
from app.web.models import Job, Stimulus, Study, User


def _study_file(tmp_path, web, **toml):
    web.write_wav(tmp_path / "s1.wav")
    path = tmp_path / "study.toml"
    path.write_text(web.toml(**toml))
    return path


def _embedded(monkeypatch, instance) -> None:
    monkeypatch.setenv("FACEPAIR_INSTANCE", str(instance))
    for name in ("DATABASE_URL", "SECRET_KEY", "MEDIA_ROOT"):
        monkeypatch.delenv(name, raising=False)


def _stub_jobs(monkeypatch, web) -> list:
    """Generation and rendering stubbed (the pipeline is tested on its own), run in this
    process with their progress bars; returns the job kinds run "apart"."""
    from app.commands import demo as commands
    from app.web.jobs import bodies

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

    monkeypatch.setitem(bodies.TASKS, "generate", fake_generate)
    monkeypatch.setitem(bodies.TASKS, "render", fake_render)
    apart = []

    def run_here(app, study_id, kinds, log=None):
        # The stubs above live in this process; the real thing spawns a fresh one, whose
        # progress bars go to the log as these do.
        apart.append((kinds, log))
        with open(log, "a", encoding="utf-8") as handle:
            real_stderr, commands.sys.stderr = commands.sys.stderr, handle
            try:
                commands.run_jobs_here(study_id, kinds)
            finally:
                commands.sys.stderr = real_stderr

    monkeypatch.setattr(commands, "_run_jobs_apart", run_here)
    return apart


def test_demo_refuses_any_other_database(app, monkeypatch, tmp_path):
    """The demo writes a login it prints: never into a database named by DATABASE_URL."""
    monkeypatch.setenv("FACEPAIR_INSTANCE", str(tmp_path / "instance"))
    monkeypatch.setenv("DATABASE_URL", app.config["SQLALCHEMY_DATABASE_URI"])
    monkeypatch.setenv("MEDIA_ROOT", app.config["MEDIA_ROOT"])
    result = CliRunner().invoke(main, ["demo", "--no-serve"])
    assert result.exit_code == 2 and "DATABASE_URL: the demo runs only on" in result.output
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(User.id))) == 0


def test_demo_sets_up_a_ready_study(monkeypatch, tmp_path, web):
    """The demo's wiring on its embedded SQLite file; the study file is the repository's
    example."""
    from app.web import create_app

    instance = tmp_path / "instance"
    _embedded(monkeypatch, instance)
    apart = _stub_jobs(monkeypatch, web)
    path = _study_file(tmp_path, web, design="all_ordered")
    result = CliRunner().invoke(
        main, ["demo", "--no-serve", "--port", "5077", "--study-file", str(path)]
    )
    assert result.exit_code == 0, result.output
    assert "participant:   http://127.0.0.1:5077/s/" in result.output
    password = (instance / "demo_password").read_text().strip()
    assert f"login:         demo@example.org / {password}" in result.output
    assert (instance / "demo_password").stat().st_mode & 0o077 == 0
    assert [kinds for kinds, _ in apart] == [("generate", "render")]  # never in the server
    key = (instance / "secret_key").read_text().strip()
    assert len(key) >= 32 and (instance / "secret_key").stat().st_mode & 0o077 == 0
    app = create_app({"TESTING": True})
    assert app.config["SQLALCHEMY_DATABASE_URI"].endswith("instance/facepair.sqlite")
    with app.app_context():
        user = db.session.scalar(sa.select(User).where(User.email == "demo@example.org"))
        assert user.check_password(password)
        study = db.session.scalar(sa.select(Study))
        assert study.status == "open" and study.slug in result.output
    # Running it again reuses the open demo study and the login.
    again = CliRunner().invoke(main, ["demo", "--no-serve", "--study-file", str(path)])
    assert again.exit_code == 0 and study.slug in again.output and password in again.output
    assert (instance / "secret_key").read_text().strip() == key
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Study.id))) == 1
        db.engine.dispose()


def test_the_demo_prints_its_links_the_login_and_the_log_and_little_else(
    monkeypatch, tmp_path, web
):
    """What a newcomer reads: one line while the study is made, then the participant link,
    the experimenter link, the login (a generated password, not a published one) and the log
    file; the migrations' INFO lines and the jobs' progress bars are in that file instead."""
    instance = tmp_path / "instance"
    _embedded(monkeypatch, instance)
    _stub_jobs(monkeypatch, web)
    path = _study_file(tmp_path, web, design="all_ordered")
    result = CliRunner().invoke(main, ["demo", "--no-serve", "--study-file", str(path)])
    assert result.exit_code == 0, result.output
    log = instance / "demo.log"
    password = (instance / "demo_password").read_text().strip()
    assert password != "facepair-demo" and len(password) >= 12
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert [line.split(":")[0].strip() for line in lines] == [
        "facepair demo",
        "participant",
        "experimenter",
        "login",
        "log",
    ], result.output
    assert lines[-1] == f"  log:           {log}"
    for noise in ("INFO", "alembic", "Running upgrade", "TRUST_PROXY", "step", "%|"):
        assert noise not in result.output
    details = log.read_text()
    assert "Running upgrade  -> 0001" in details  # alembic's INFO, in the log
    assert "generate: 100%" in details and "render" in details  # the progress bars
    # the second run: the greeting alone
    again = CliRunner().invoke(main, ["demo", "--no-serve", "--study-file", str(path)])
    assert [line.split(":")[0].strip() for line in again.output.splitlines() if line] == [
        "participant",
        "experimenter",
        "login",
        "log",
    ]


def test_a_changed_demo_password_is_set_back_to_the_printed_one(monkeypatch, tmp_path, web):
    """An older demo's published password (or one changed on the web) never outlives a run:
    the login printed is the login that works."""
    from app.web import create_app
    from app.web.infra.accounts import create_user

    instance = tmp_path / "instance"
    _embedded(monkeypatch, instance)
    _stub_jobs(monkeypatch, web)
    app = create_app({"TESTING": True})
    with app.app_context():
        upgrade()
        create_user("demo@example.org", "facepair-demo-old")
        db.session.commit()
        db.engine.dispose()
    path = _study_file(tmp_path, web, design="all_ordered")
    result = CliRunner().invoke(main, ["demo", "--no-serve", "--study-file", str(path)])
    assert result.exit_code == 0, result.output
    password = (instance / "demo_password").read_text().strip()
    with app.app_context():
        user = db.session.scalar(sa.select(User).where(User.email == "demo@example.org"))
        assert user.check_password(password) and not user.check_password("facepair-demo-old")
        db.engine.dispose()


def test_the_demo_serves_without_the_proxy_warning_and_logs_to_its_file(
    app, monkeypatch, tmp_path, capsys
):
    """The demo serves on this machine alone: no production warning about a front proxy, and
    gunicorn's own lines go to the log file; ``facepair serve`` still warns."""
    from gunicorn.app.base import BaseApplication

    from app.commands.webapp import serve_app

    served = []
    monkeypatch.setattr(BaseApplication, "run", lambda self: served.append(self.cfg))
    log = tmp_path / "demo.log"
    serve_app(app, "127.0.0.1", 5077, workers=1, dev=False, log=log)
    assert "TRUST_PROXY" not in capsys.readouterr().err
    assert served[0].errorlog == str(log) and served[0].accesslog == str(log)
    serve_app(app, "127.0.0.1", 5077, workers=1, dev=False)
    assert "TRUST_PROXY is 0" in capsys.readouterr().err
    assert served[1].accesslog == "-"


def test_demo_jobs_run_in_a_spawned_process(monkeypatch, tmp_path, web):
    """The demo's jobs run apart from the process that will serve, their output into the log:
    a failing job there is reported in one line from the child's error (here: render before
    the tracks exist), naming the log."""
    from app.commands.demo import _run_jobs_apart
    from app.trials.studyfile import load_study_file
    from app.web import create_app
    from app.web.infra.accounts import create_user
    from app.web.study.studies import create_study

    _embedded(monkeypatch, tmp_path / "instance")
    app = create_app({"TESTING": True})
    log = tmp_path / "demo.log"
    with app.app_context():
        upgrade()
        user = create_user("demo-test@example.org", "long enough pw")
        db.session.flush()
        study = create_study(user, load_study_file(_study_file(tmp_path, web)))
        db.session.commit()
        with pytest.raises(click.ClickException, match="render of study") as raised:
            _run_jobs_apart(app, study.id, ("render",), log)
        assert "generate the tracks first" in raised.value.message
        assert raised.value.message.endswith(f"details in {log}")
        assert "facepair: error: " in log.read_text()
        job = db.session.scalar(sa.select(Job))
        assert job.status == "failed" and "generate the tracks first" in job.message
        db.session.remove()
        db.engine.dispose()


def test_the_greeting_and_the_password(tmp_path):
    from pathlib import Path

    from app.commands.demo import PASSWORD_LETTERS, demo_password, greeting

    text = greeting("http://h:1", ["a", "b"], 3, "pw", Path("/l/demo.log"))
    assert text.splitlines()[1:] == [
        "  participant:   http://h:1/s/a",
        "  participant:   http://h:1/s/b",
        "  experimenter:  http://h:1/experimenter/studies/3",
        "  login:         demo@example.org / pw",
        "  log:           /l/demo.log",
    ]
    password = demo_password(tmp_path)
    assert set(password.replace("-", "")) <= set(PASSWORD_LETTERS)
    assert password == demo_password(tmp_path) != demo_password(tmp_path / "b")
    assert (tmp_path / "demo_password").stat().st_mode & 0o077 == 0
