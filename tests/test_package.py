"""The study package (``app.web.study.package``, read back by ``app.analysis.package``): one
zip with the study file, the data, the report and a manifest; ``facepair analyze package.zip``
gives the report's numbers exactly."""

import hashlib
import io
import json
import zipfile

import pytest
from click.testing import CliRunner

from app import __version__
from app.cli import main
from app.web.extensions import db
from app.web.infra.storage import media_dir
from app.web.models import Study, Trial

EXCLUDE = 'exclude = "undecided>0.5"\n'


def _run(app, participant, slug, *, catch_answer, first="left"):
    participant.client = app.test_client()
    participant.join(slug)
    n = 0
    while (trial := participant.current_trial()) is not None:
        with app.app_context():
            kind = db.session.get(Trial, trial).kind
        choice = catch_answer if kind == "catch" else (first if n % 3 else "right")
        participant.vote(trial, choice)
        n += 1


def _closed_study(app, client, web, participant):
    study_id = web.study(design="all_ordered", catch=1, extra=EXCLUDE)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    for catch, first in (("undecided", "left"), ("undecided", "right"), ("left", "left")):
        _run(app, participant, slug, catch_answer=catch, first=first)
    web.login(client)
    token = web.csrf(client, f"/experimenter/studies/{study_id}")
    client.post(f"/experimenter/studies/{study_id}/status/close", data={"csrf_token": token})
    return study_id


def _comparable(results):
    """Every number the report holds; the source's folder and the study head (the report's
    date and the study's description) are not numbers of the analysis."""
    out = {k: v for k, v in results.items() if k != "study"}
    out["input"] = {k: v for k, v in results["input"].items() if k != "source"}
    return out


@pytest.mark.slow
def test_the_package_holds_everything_and_reproduces_the_report(
    app, client, web, participant, tmp_path, monkeypatch
):
    study_id = _closed_study(app, client, web, participant)
    response = client.get(f"/experimenter/studies/{study_id}/package.zip")
    assert response.status_code == 200 and response.mimetype == "application/zip"
    assert response.headers["Cache-Control"] == "no-store"
    assert 'filename="Test_study-package.zip"' in response.headers["Content-Disposition"]
    archive = zipfile.ZipFile(io.BytesIO(response.data))
    names = set(archive.namelist())
    assert names == {
        "manifest.json",
        "study.toml",
        "votes.csv",
        "participants.csv",
        "answers.csv",
        "report.html",
        "report.pdf",
        "results.json",
    }
    manifest = json.loads(archive.read("manifest.json"))
    assert manifest["format"] == "facepair-study-package/1"
    assert set(manifest["files"]) == names - {"manifest.json"}
    for name, digest in manifest["files"].items():
        assert hashlib.sha256(archive.read(name)).hexdigest() == digest, name
    assert b'title = "Test study"' in archive.read("study.toml")
    assert manifest["software"]["facepair"] == __version__
    assert manifest["software"]["numpy"] and manifest["software"]["python"]
    assert set(manifest["seeds"]["participants"]) == {"P0000", "P0001", "P0002"}
    assert manifest["seeds"]["study"] == 11 and manifest["seeds"]["bootstrap"] == 0
    analysis = manifest["analysis"]
    assert analysis["conditions"] == ["none", "random"] and analysis["exclude"] == "undecided>0.5"
    assert analysis["command"] == (
        "facepair analyze Test_study-package.zip --json results.json --report report.html "
        "--pdf report.pdf"
    )
    kinds = {entry["kind"] for entry in manifest["media"]}
    assert {"clip", "video"} <= kinds
    with app.app_context():
        folder = media_dir(db.session.get(Study, study_id))
    for entry in manifest["media"]:
        data = (folder / entry["path"]).read_bytes()
        assert entry["sha256"] == hashlib.sha256(data).hexdigest(), entry
    assert str(tmp_path) not in json.dumps(manifest)  # no server folder named
    # The command, run on the package alone, gives every number of the report.
    monkeypatch.chdir(tmp_path)
    (tmp_path / "Test_study-package.zip").write_bytes(response.data)
    command = analysis["command"].split()[1:]
    result = CliRunner().invoke(main, command)
    assert result.exit_code == 0, result.output
    again = json.loads((tmp_path / "results.json").read_text())
    reported = json.loads(archive.read("results.json"))
    assert _comparable(again) == _comparable(reported)
    assert reported["input"]["left_out"] and again["quality"]["rules"] == ["undecided>0.5"]
    assert (tmp_path / "report.pdf").read_bytes().startswith(b"%PDF")


def test_a_study_without_a_report_has_no_package_yet(app, client, web):
    study_id = web.study(design="all_ordered")
    web.login(client)
    response = client.get(f"/experimenter/studies/{study_id}/package.zip")
    assert response.status_code == 302
    page = client.get(response.headers["Location"]).get_data(as_text=True)
    assert "No package: no report yet: close the study (or press Write report) first." in page


@pytest.mark.slow
def test_a_rating_studys_package_holds_its_ratings_and_reproduces_the_report(
    app, client, web, participant, tmp_path, monkeypatch
):
    from tests.test_ratings import _rate_all

    study_id = web.study(design="rating", catch_kind="instructed", catch=1)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    for score, check in ((4, 1), (5, 1), (3, 1), (5, 3)):  # the last misses the check
        _rate_all(app, client, participant, slug, score, check=check)
        client.delete_cookie(f"fp-{study_id}")
    web.login(client)
    token = web.csrf(client, f"/experimenter/studies/{study_id}")
    client.post(f"/experimenter/studies/{study_id}/status/close", data={"csrf_token": token})
    response = client.get(f"/experimenter/studies/{study_id}/package.zip")
    assert response.status_code == 200, response.headers.get("Location")
    archive = zipfile.ZipFile(io.BytesIO(response.data))
    names = set(archive.namelist())
    assert "ratings.csv" in names and "votes.csv" not in names and "results.json" in names
    manifest = json.loads(archive.read("manifest.json"))
    assert manifest["study"]["design"] == "rating"
    for name, digest in manifest["files"].items():
        assert hashlib.sha256(archive.read(name)).hexdigest() == digest, name
    monkeypatch.chdir(tmp_path)
    (tmp_path / "Test_study-package.zip").write_bytes(response.data)
    result = CliRunner().invoke(main, manifest["analysis"]["command"].split()[1:])
    assert result.exit_code == 0, result.output
    again = json.loads((tmp_path / "results.json").read_text())
    reported = json.loads(archive.read("results.json"))
    assert again["kind"] == "rating" and _comparable(again) == _comparable(reported)
    assert again["input"]["source"] == "Test_study-package.zip/ratings.csv"
    assert len(again["input"]["left_out"]) == 1
    # a changed table is refused: its numbers would not be the report's
    changed = tmp_path / "changed.zip"
    with zipfile.ZipFile(changed, "w") as out:
        for name in names:
            data = archive.read(name)
            out.writestr(name, data.replace(b",5,", b",1,") if name == "ratings.csv" else data)
    refused = CliRunner().invoke(main, ["analyze", str(changed)])
    assert refused.exit_code != 0 and "ratings.csv: its SHA-256 is not the manifest's" in (
        refused.output
    )


def test_the_cli_writes_the_package_and_its_report(app, web, participant, monkeypatch):
    monkeypatch.setenv("DATABASE_URL", app.config["SQLALCHEMY_DATABASE_URI"])
    monkeypatch.setenv("MEDIA_ROOT", app.config["MEDIA_ROOT"])
    study_id = web.study(design="all_ordered")
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    _run(app, participant, slug, catch_answer="undecided")
    out = app.instance_path + "/package"
    runner = CliRunner()
    written = runner.invoke(main, ["study", "export", str(study_id), "--out", out, "--package"])
    assert written.exit_code == 0, written.output
    with zipfile.ZipFile(f"{out}/Test_study-package.zip") as archive:
        assert {"report.html", "results.json", "votes.csv"} <= set(archive.namelist())
    both = runner.invoke(
        main, ["study", "export", str(study_id), "--out", out, "--package", "--pilots"]
    )
    assert both.exit_code == 2 and "pilots:" in both.output
