"""The report a study writes when it closes: its head, who was left out and why, no server
path, the PDF on the web, and the command that reproduces it from the exported votes."""

import re

import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Job, Study, Trial


def _run(app, participant, slug, *, catch_answer, finish=True):
    participant.client = app.test_client()
    participant.join(slug)
    while (trial := participant.current_trial()) is not None:
        with app.app_context():
            kind = db.session.get(Trial, trial).kind
        participant.vote(trial, catch_answer if kind == "catch" else "left")
        if not finish:
            return


def test_the_closing_report(app, client, web, participant, tmp_path, monkeypatch):
    study_id = web.study(design="all_ordered", catch=1)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    _run(app, participant, slug, catch_answer="undecided")
    _run(app, participant, slug, catch_answer="left")
    _run(app, participant, slug, catch_answer="undecided", finish=False)
    web.login(client)
    token = web.csrf(client, f"/experimenter/studies/{study_id}")
    client.post(f"/experimenter/studies/{study_id}/status/close", data={"csrf_token": token})
    with app.app_context():
        job = db.session.scalar(sa.select(Job).where(Job.kind == "report"))
        assert job.status == "done", job.message
    response = client.get(f"/experimenter/studies/{study_id}/report/")
    html = response.get_data(as_text=True)
    response.close()
    html = html.replace("&#x27;", "'").replace("&quot;", '"')
    assert "<h1>Test study</h1>" in html and "Report written 20" in html
    assert "in-memory votes" not in html
    assert "1 participant cast 4 votes on 1 clip " in html
    assert "P0001: failed a catch trial (0 of 1 passed)" in html
    assert "P0002: did not finish" in html
    assert str(tmp_path) not in html and "study-" not in html
    command = re.search(r"(facepair analyze votes\.csv [^<]*?)</p>", html).group(1)
    pdf = client.get(f"/experimenter/studies/{study_id}/report/report.pdf")
    assert pdf.status_code == 200 and pdf.data.startswith(b"%PDF")
    pdf.close()
    # The command, run on the exported CSV, gives the report's statistics.
    import json
    import shlex

    from click.testing import CliRunner

    from app.cli import main

    (tmp_path / "again").mkdir()
    monkeypatch.chdir(tmp_path / "again")
    (tmp_path / "again" / "votes.csv").write_bytes(
        client.get(f"/experimenter/studies/{study_id}/votes.csv").data
    )
    result = CliRunner().invoke(main, [*shlex.split(command)[1:], "--json", "again.json"])
    assert result.exit_code == 0, result.output
    again = json.loads((tmp_path / "again" / "again.json").read_text())
    assert again["input"]["participants"] == 1 and again["input"]["votes"] == 4
    assert set(again["input"]["left_out"]) == {"P0001", "P0002"}


def test_the_report_analyses_the_table_the_csv_holds(app, web, participant, tmp_path):
    """What the web report analyses is what the CSV export holds: same columns, same counts."""
    import io

    from app.analysis.results import analyze
    from app.analysis.votes import VOTE_COLUMNS, read_votes
    from app.web.study.exports import vote_rows, votes_csv, votes_table

    study_id = web.study(design="all_ordered")
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    _run(app, participant, slug, catch_answer="left")
    with app.app_context():
        study = db.session.get(Study, study_id)
        rows = vote_rows(study)
        assert rows and all(set(row) <= set(VOTE_COLUMNS) for row in rows)
        table = votes_table(study)
        text = votes_csv(study)
    (tmp_path / "votes.csv").write_text(text, encoding="utf-8")
    again = read_votes(tmp_path / "votes.csv")
    assert len(table) == len(again) == len(rows)
    direct, reread = analyze(table), analyze(again)
    assert {**direct["input"], "source": None} == {**reread["input"], "source": None}
    assert direct["pooled"]["ballots"] == reread["pooled"]["ballots"]
    assert io.StringIO(text).readline().strip().split(",") == list(VOTE_COLUMNS)


def test_a_closed_study_without_votes_gets_a_no_votes_report(app, client, web, participant):
    """Every participant a pilot or excluded: the report job ends done with a page that says
    there is nothing to analyse (and who was left out), and no PDF is offered."""
    study_id = web.study(design="all_ordered")
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    _run(app, participant, slug, catch_answer="left", finish=False)  # one vote, never finished
    web.login(client)
    token = web.csrf(client, f"/experimenter/studies/{study_id}")
    client.post(f"/experimenter/studies/{study_id}/status/close", data={"csrf_token": token})
    with app.app_context():
        jobs = db.session.scalars(sa.select(Job).where(Job.kind == "report")).all()
        assert [job.status for job in jobs] == ["done"], [job.message for job in jobs]
        assert jobs[0].message.startswith("no votes to analyse")
    response = client.get(f"/experimenter/studies/{study_id}/report/")
    html = response.get_data(as_text=True)
    response.close()
    assert response.status_code == 200
    assert "No votes to analyse yet" in html and "<main>" in html
    assert "1 participant joined: 1 left out by exclusions and 0 pilots" in html
    assert "P0000: did not finish" in html
    assert "Error" not in html and "/report/" not in html
    page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    assert 'id="report-pdf"' not in page and "Retry" not in page
    assert client.get(f"/experimenter/studies/{study_id}/report/report.pdf").status_code == 404


def test_a_failed_job_names_the_file_not_the_server_path():
    from app.errors import InputError
    from app.web.jobs.tasks import failure_message

    message = failure_message(
        InputError("no valid votes to analyse", path="/srv/facepair/media/study-7/votes.csv")
    )
    assert message == "votes.csv: no valid votes to analyse"
    located = failure_message(InputError("bad value", path="/tmp/x/clip.fap", line=3))
    assert located == "clip.fap:3: bad value"
    other = failure_message(OSError("cannot write /var/lib/facepair/media/study-7/report.pdf"))
    assert other == "cannot write report.pdf" and "Error" not in other
