"""``facepair db`` and ``facepair study list/open/pause/close/reopen/export``: a study's life
cycle from the shell, with one line and exit 2 for every mistake."""

import csv
import io

import sqlalchemy as sa
from click.testing import CliRunner

from app.cli import main
from app.web.extensions import db
from app.web.models import Participant, Study
from tests.conftest import ParticipantActions


def _env(monkeypatch, app):
    monkeypatch.setenv("DATABASE_URL", app.config["SQLALCHEMY_DATABASE_URI"])
    monkeypatch.setenv("MEDIA_ROOT", app.config["MEDIA_ROOT"])


def test_db_upgrade_and_current_on_an_empty_database(monkeypatch, tmp_path):
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'new.sqlite'}")
    runner = CliRunner()
    before = runner.invoke(main, ["db", "current"])
    assert before.exit_code == 0 and "no schema yet" in before.output
    listed = runner.invoke(main, ["study", "list"])
    assert listed.exit_code == 2
    assert listed.output.strip() == (
        "facepair: error: the database has no schema yet: run 'facepair db upgrade'"
    )
    upgraded = runner.invoke(main, ["db", "upgrade"])
    assert upgraded.exit_code == 0 and "(was empty)" in upgraded.output
    after = runner.invoke(main, ["db", "current"])
    assert after.exit_code == 0 and after.output.strip().endswith("(up to date)")
    again = runner.invoke(main, ["db", "upgrade"])
    assert again.exit_code == 0 and "was" not in again.output
    assert runner.invoke(main, ["study", "list"]).output.strip() == "no studies"


def test_list_open_close_and_export(app, monkeypatch, web):
    _env(monkeypatch, app)
    study_id = web.study(status="ready")
    runner = CliRunner()
    listed = runner.invoke(main, ["study", "list"])
    assert listed.exit_code == 0, listed.output
    assert f"{study_id:>4}  ready" in listed.output and "Test study" in listed.output
    assert runner.invoke(main, ["study", "list", "--owner", "else@x.org"]).output.strip() == (
        "no studies"
    )

    opened = runner.invoke(main, ["study", "open", str(study_id)])
    assert opened.exit_code == 0 and opened.output.strip() == f"study {study_id} is open"
    again = runner.invoke(main, ["study", "open", str(study_id)])
    assert again.exit_code == 2
    assert again.output.strip() == "facepair: error: STUDY_ID: cannot open a study that is open"

    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    person = ParticipantActions(app.test_client(), app)
    person.join(slug)
    assert person.vote(person.current_trial(), "right").status_code == 201

    closed = runner.invoke(main, ["study", "close", str(study_id)])
    assert closed.exit_code == 0 and closed.output.strip() == f"study {study_id} is closed"
    with app.app_context():
        assert db.session.get(Study, study_id).status == "closed"
    out = app.instance_path + "/export"
    exported = runner.invoke(main, ["study", "export", str(study_id), "--out", out])
    assert exported.exit_code == 0, exported.output
    with open(f"{out}/votes.csv", encoding="utf-8") as handle:
        votes = list(csv.DictReader(handle))
    assert [v["choice"] for v in votes] == ["right"]
    with open(f"{out}/participants.csv", encoding="utf-8") as handle:
        people = list(csv.DictReader(io.StringIO(handle.read())))
    assert [p["participant"] for p in people] == [votes[0]["participant"]]
    missing = runner.invoke(main, ["study", "close", "999"])
    assert missing.exit_code == 2 and "no study 999" in missing.output
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Study.id))) == 1


def test_the_shell_export_neutralises_formulas(app, monkeypatch, web):
    _env(monkeypatch, app)
    extra = '[[questions]]\nname = "comments"\ntext = "Any comments?"\npage = "after"\n'
    study_id = web.study(design="all_ordered", extra=extra)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    person = ParticipantActions(app.test_client(), app)
    person.join(slug)
    with app.app_context():
        row = db.session.scalar(sa.select(Participant))
        row.answers = {"after": {"comments": "@SUM(1+1)*cmd|' /C calc'!A0"}}
        db.session.commit()
    out = app.instance_path + "/export-formulas"
    exported = CliRunner().invoke(main, ["study", "export", str(study_id), "--out", out])
    assert exported.exit_code == 0, exported.output
    with open(f"{out}/answers.csv", encoding="utf-8", newline="") as handle:
        answers = list(csv.DictReader(handle))
    assert answers[0]["comments"] == "'@SUM(1+1)*cmd|' /C calc'!A0"


def test_a_rating_study_exports_its_ratings(app, monkeypatch, web, tmp_path):
    _env(monkeypatch, app)
    study_id = web.study(design="rating", catch_kind="instructed")
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    client = app.test_client()
    person = ParticipantActions(client, app)
    token = person.join(slug)
    rated = client.post(
        "/api/v1/ratings",
        json={
            "token": token,
            "trial_id": person.current_trial(),
            "score": 4,
            "plays": 1,
            "idempotency_key": "export-rating-1",
        },
    )
    assert rated.status_code == 201, rated.get_json()
    out = tmp_path / "export"
    exported = CliRunner().invoke(main, ["study", "export", str(study_id), "--out", str(out)])
    assert exported.exit_code == 0, exported.output
    assert "ratings.csv" in exported.output and not (out / "votes.csv").exists()
    with open(out / "ratings.csv", encoding="utf-8") as handle:
        ratings = list(csv.DictReader(handle))
    assert [(r["score"], r["scale"], r["kind"]) for r in ratings] == [("4", "acr5", "trial")]


def test_renditions_makes_the_missing_webms_of_an_open_study(app, monkeypatch, web):
    """Clips rendered before renditions existed get their WebM from their MP4, blinded as it
    is; clips that have one keep it; a second run has nothing to do."""
    from app.web.infra.storage import media_dir
    from app.web.models import Stimulus

    _env(monkeypatch, app)
    study_id = web.study(status="open")
    runner = CliRunner()
    made = runner.invoke(main, ["study", "renditions", str(study_id)])
    assert made.exit_code == 0, made.output
    with app.app_context():
        study = db.session.get(Study, study_id)
        stimuli = db.session.scalars(sa.select(Stimulus).where(Stimulus.study_id == study_id))
        webms = {s.video_path: s.webm_path for s in stimuli}
        assert webms and all(w == v.removesuffix(".mp4") + ".webm" for v, w in webms.items())
        for webm in webms.values():
            data = (media_dir(study) / webm).read_bytes()
            assert data[:4] == b"\x1a\x45\xdf\xa3"  # an EBML (WebM) header
            assert b"Lavc" not in data and b"libvpx" not in data
        assert study.status == "open"
    n = len(webms)
    assert made.output.strip().endswith(f"study {study_id}: {n} WebM renditions made")
    again = runner.invoke(main, ["study", "renditions", str(study_id)])
    assert again.exit_code == 0
    assert again.output.strip().endswith(f"study {study_id}: 0 WebM renditions made")
    missing = runner.invoke(main, ["study", "renditions", "999"])
    assert missing.exit_code == 2
    assert missing.output.strip() == (
        "facepair: error: STUDY_ID: no study 999 (see 'facepair study list')"
    )
