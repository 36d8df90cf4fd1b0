import shutil

import sqlalchemy as sa
from click.testing import CliRunner

from app.cli import main
from app.extensions import db
from app.models import Stimulus, Study, User


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
    added = runner.invoke(main, ["experimenter", "add", "Lab@Example.org"],
                          input="long enough pw\nlong enough pw\n")
    assert added.exit_code == 0, added.output
    short = runner.invoke(main, ["experimenter", "add", "x@example.org", "--password", "short"])
    assert short.exit_code == 2 and "password: at least 8 characters" in short.output
    path = _study_file(tmp_path, web)
    created = runner.invoke(main, ["study", "create", str(path), "--owner", "lab@example.org"])
    assert created.exit_code == 0, created.output
    assert "participant link: /s/" in created.output
    with app.app_context():
        study = db.session.scalar(sa.select(Study))
        assert (study.title, study.owner.email, study.status) == (
            "Test study", "lab@example.org", "draft")


def test_study_create_errors_are_one_line(app, monkeypatch, tmp_path, web):
    _env(monkeypatch, app)
    path = _study_file(tmp_path, web)
    unknown = CliRunner().invoke(main, ["study", "create", str(path), "--owner", "no@x.org"])
    assert unknown.exit_code == 2 and "--owner: no experimenter" in unknown.output
    web.user()
    bad = tmp_path / "bad.toml"
    bad.write_text(web.toml(design="zigzag"))
    result = CliRunner().invoke(main, ["study", "create", str(bad), "--owner",
                                       "exp@example.org"])
    assert result.exit_code == 2
    assert result.output.strip().endswith("expected one of all_ordered, reference, "
                                          "unordered_counterbalanced, got 'zigzag'")
    assert "Traceback" not in result.output


def test_demo_sets_up_a_ready_study(app, monkeypatch, tmp_path, web):
    """The demo's wiring, with generation and rendering stubbed (the pipeline is tested on its
    own); the study file is the repository's example."""
    from app.jobs import tasks

    _env(monkeypatch, app)

    def fake_generate(study, progress):
        progress(1, 1)
        return "stub"

    def fake_render(study, progress):
        from app.storage import media_dir

        for stimulus in db.session.scalars(sa.select(Stimulus)
                                           .where(Stimulus.study_id == study.id)):
            stimulus.video_path = f"videos/{stimulus.id}.mp4"
            (media_dir(study) / "videos").mkdir(exist_ok=True)
            shutil.copyfile(web.tiny_video, media_dir(study) / stimulus.video_path)
        db.session.commit()
        return "stub"

    monkeypatch.setitem(tasks.TASKS, "generate", fake_generate)
    monkeypatch.setitem(tasks.TASKS, "render", fake_render)
    path = _study_file(tmp_path, web, design="all_ordered")
    result = CliRunner().invoke(main, ["demo", "--no-serve", "--port", "5077",
                                       "--study-file", str(path)])
    assert result.exit_code == 0, result.output
    assert "participant:   http://127.0.0.1:5077/s/" in result.output
    assert "login:         demo@facepair.local / facepair-demo" in result.output
    with app.app_context():
        user = db.session.scalar(sa.select(User).where(User.email == "demo@facepair.local"))
        assert user.check_password("facepair-demo")
        study = db.session.scalar(sa.select(Study))
        assert study.status == "open" and study.slug in result.output
    # Running it again reuses the open demo study.
    again = CliRunner().invoke(main, ["demo", "--no-serve", "--study-file", str(path)])
    assert again.exit_code == 0 and study.slug in again.output
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Study.id))) == 1
