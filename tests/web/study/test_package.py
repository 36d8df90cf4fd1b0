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
    from tests.support.rating import rate_all

    study_id = web.study(design="rating", catch_kind="instructed", catch=1)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    for score, check in ((4, 1), (5, 1), (3, 1), (5, 3)):  # the last misses the check
        rate_all(app, client, participant, slug, score, check=check)
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


def _pdf_text(data: bytes) -> str:
    """The text a PDF draws (the strings of its ``Tj``/``TJ`` operators, a ``TJ`` array's pieces
    joined), from its streams inflated: enough to grep a report's PDF for a path without a PDF
    library."""
    import re
    import zlib

    streams = []
    for raw in re.findall(rb"stream\r?\n(.*?)\r?\nendstream", data, re.S):
        try:
            streams.append(zlib.decompress(raw))
        except zlib.error:
            streams.append(raw)
    text = []
    for stream in streams:
        for array in re.findall(rb"\[((?:\((?:\\.|[^\\)])*\)|[^\](])*)\]\s*TJ", stream):
            text.append(b"".join(re.findall(rb"\(((?:\\.|[^\\)])*)\)", array)))
        text += re.findall(rb"\(((?:\\.|[^\\)])*)\)\s*Tj", stream)
    return b"\n".join([*streams, *text]).decode("latin-1")


#: Where an absolute path of a Unix or Windows machine starts (after a quote, a space, an
#: equals sign or a bracket): what a file inside a package must never name.
ABSOLUTE_PATH = (
    r"""(?:^|[\s"'(=\[,])"""
    r"(?:/(?:tmp|home|root|srv|var|usr|opt|work|mnt|data|Users|private)/|[A-Za-z]:\\)"
)


def _assert_no_server_path(app, archive: zipfile.ZipFile, *also: str) -> None:
    """No member of ``archive`` (a PDF's text layer and inflated streams included) names the
    instance folder, the media folder, the working directory or any absolute path."""
    import os
    import re

    folders = {app.instance_path, app.config["MEDIA_ROOT"], os.getcwd(), *also}
    for name in archive.namelist():
        data = archive.read(name)
        texts = [data.decode("utf-8", errors="replace")]
        if name.endswith(".pdf"):
            texts.append(_pdf_text(data))
        for text in texts:
            for folder in folders:
                assert folder not in text, f"{name} names {folder}"
            found = re.search(ABSOLUTE_PATH, text, re.M)
            assert found is None, f"{name}: {text[max(0, found.start() - 80) : found.end() + 80]!r}"


@pytest.mark.slow
def test_no_file_of_a_package_names_a_server_path(
    app, client, web, participant, tmp_path, repo_root
):
    """A pair study's and a rating study's packages name their files by their place in the
    package (``votes.csv``, ``ratings.csv``): never the server's instance or media folder,
    in results.json, the report's HTML or its PDF."""
    from tests.support.rating import rate_all

    rating = web.study(design="rating", catch_kind="instructed", catch=1)
    with app.app_context():
        slug = db.session.get(Study, rating).slug
    for score in (4, 5, 3):
        rate_all(app, client, participant, slug, score)
        client.delete_cookie(f"fp-{rating}")
    pair = _closed_study(app, client, web, participant)
    token = web.csrf(client, f"/experimenter/studies/{rating}")
    client.post(f"/experimenter/studies/{rating}/status/close", data={"csrf_token": token})
    for study_id, table in ((pair, "votes.csv"), (rating, "ratings.csv")):
        response = client.get(f"/experimenter/studies/{study_id}/package.zip")
        assert response.status_code == 200, response.headers.get("Location")
        archive = zipfile.ZipFile(io.BytesIO(response.data))
        assert {"report.pdf", "results.json"} <= set(archive.namelist())
        assert json.loads(archive.read("results.json"))["input"]["source"] == table
        _assert_no_server_path(app, archive, str(tmp_path), str(repo_root))


def test_a_package_names_a_study_files_media_by_name(app, client, web, tmp_path):
    """A study created from a file naming its speech by an absolute path (``facepair study
    create`` on the server) is packaged with a study file naming it by file name, as the web
    form keeps one; and a report written before reports named their table by its place in the
    package (results.json's ``input.source``) is packaged naming it by its place."""
    from app.trials.studyfile import loads_study
    from app.web.infra.storage import report_path
    from app.web.study.package import build_package
    from app.web.study.studies import create_study

    web.write_wav(tmp_path / "s1.wav")
    text = web.toml(design="all_ordered").replace('"s1.wav"', json.dumps(str(tmp_path / "s1.wav")))
    with app.app_context():
        owner = db.session.get(Study, web.study()).owner
        study = create_study(owner, loads_study(text, base_dir=tmp_path), source_toml=text)
        db.session.commit()
        folder = report_path(study).parent
        folder.mkdir(parents=True)
        (folder / "votes.csv").write_text("participant\n")
        (folder / "report.html").write_text("<p>votes.csv</p>")
        results = {"input": {"source": str(folder / "votes.csv")}, "options": {}, "conditions": []}
        (folder / "results.json").write_text(json.dumps(results))
        archive = zipfile.ZipFile(io.BytesIO(build_package(study)))
    assert json.loads(archive.read("results.json"))["input"]["source"] == "votes.csv"
    assert 'audio = "s1.wav"' in archive.read("study.toml").decode()
    manifest = json.loads(archive.read("manifest.json"))
    for name, digest in manifest["files"].items():
        assert hashlib.sha256(archive.read(name)).hexdigest() == digest, name
    _assert_no_server_path(app, archive, str(tmp_path))
