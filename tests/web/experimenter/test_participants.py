"""The monitor's participant table, exclusion by hand, and the statuses the export carries."""

import csv
import io
import re

import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study, StudyList, Trial
from tests.support.studies import study_slug


def _run(app, participant, slug, *, catch_answer, pid):
    """A participant who answers every real trial "left" and every catch trial
    ``catch_answer``."""
    participant.client = app.test_client()
    participant.join(slug, f"PROLIFIC_PID={pid}")
    while (trial := participant.current_trial()) is not None:
        with app.app_context():
            kind = db.session.get(Trial, trial).kind
        assert (
            participant.vote(trial, catch_answer if kind == "catch" else "left").status_code == 201
        )


def test_table_statuses_catch_scores_and_the_export(app, client, web, participant):
    study_id = web.study(design="all_ordered", catch=2)
    slug = study_slug(app, study_id)
    _run(app, participant, slug, catch_answer="undecided", pid="5f0000000000000000000001")
    _run(app, participant, slug, catch_answer="left", pid="5f0000000000000000000002")
    participant.client = app.test_client()
    participant.join(slug)  # started, never voted
    web.login(client)
    monitor = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    rows = {m[0]: m[1] for m in re.findall(r'id="participant-(P\d+)" data-status="(\w+)"', monitor)}
    assert rows == {"P0000": "finished", "P0001": "finished", "P0002": "in_progress"}
    assert "2/2" in monitor and "0/2" in monitor
    assert "5f0000000000000000000001" not in monitor  # pseudonymised until revealed
    assert "no: failed a catch trial (0 of 2 passed)" in monitor
    revealed = client.get(f"/experimenter/studies/{study_id}/monitor?reveal=1").get_data(
        as_text=True
    )
    assert "5f0000000000000000000001" in revealed
    export = list(
        csv.DictReader(
            io.StringIO(
                client.get(f"/experimenter/studies/{study_id}/votes.csv").get_data(as_text=True)
            )
        )
    )
    kinds = {(r["participant"], r["kind"]) for r in export}
    assert ("P0000", "catch") in kinds and ("P0001", "trial") in kinds
    excluded = {r["participant"]: r["excluded"] for r in export}
    assert excluded == {"P0000": "", "P0001": "failed a catch trial (0 of 2 passed)"}
    assert {r["status"] for r in export} == {"finished"}
    assert all(r["prolific_id"].startswith("anon-") for r in export)
    # The one who failed gave the list slot back (the one who started still holds theirs).
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.sum(StudyList.n_assigned))) == 2


def test_excluding_by_hand_frees_the_list_slot(app, client, web, participant):
    study_id = web.study(design="all_ordered")
    slug = study_slug(app, study_id)
    _run(app, participant, slug, catch_answer="undecided", pid="pid-a")
    web.login(client)
    page = f"/experimenter/studies/{study_id}/monitor"
    token = web.csrf(client, page + "?refresh=0")
    base = f"/experimenter/studies/{study_id}/participants/exclude"
    # No reason: refused.
    client.post(base, data={"csrf_token": token, "participant": "P0000", "how": "excluded"})
    with app.app_context():
        assert db.session.scalar(sa.select(Participant.excluded_at)) is None
    response = client.post(
        base,
        data={
            "csrf_token": token,
            "participant": "p0",
            "how": "excluded",
            "reason": "spoke to a neighbour",
        },
    )
    assert response.status_code == 302
    with app.app_context():
        person = db.session.scalar(sa.select(Participant))
        assert person.exclusion_reason == "spoke to a neighbour"
        assert db.session.scalar(sa.select(sa.func.sum(StudyList.n_assigned))) == 0
    monitor = client.get(page).get_data(as_text=True)
    assert 'data-status="excluded"' in monitor
    assert "no: excluded: spoke to a neighbour" in monitor
    # Excluding twice changes nothing, and the slot is not given back twice.
    client.post(base, data={"csrf_token": token, "participant": "P0000", "how": "returned"})
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.sum(StudyList.n_assigned))) == 0
        assert db.session.scalar(sa.select(Participant.exclusion_reason)) == (
            "spoke to a neighbour"
        )


def test_a_returned_submission(app, client, web, participant):
    study_id = web.study(design="all_ordered")
    participant.join(study_slug(app, study_id))
    web.login(client)
    token = web.csrf(client, f"/experimenter/studies/{study_id}/monitor?refresh=0")
    client.post(
        f"/experimenter/studies/{study_id}/participants/exclude",
        data={"csrf_token": token, "participant": "P0000", "how": "returned"},
    )
    monitor = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    assert 'data-status="returned"' in monitor
    # Coming back does not take the slot again.
    assert participant.current_trial() is not None
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.sum(StudyList.n_assigned))) == 0


SCREENING = """
[attention]
max_failed = 1

[[questions]]
name = "comments"
text = "Anything to tell us first?"
page = "before"
required = false
"""


def _csv(client, url):
    return list(csv.DictReader(io.StringIO(client.get(url).get_data(as_text=True))))


def _answer_before(participant, token):
    url = f"/p/{token}/questions/before"
    form = participant.client.get(url).get_data(as_text=True)
    csrf = re.search(r'name="csrf_token" type="hidden" value="([^"]+)"', form).group(1)
    assert participant.client.post(url, data={"csrf_token": csrf, "comments": "ok"}).status_code
    return token


def test_a_screened_out_participant_has_one_status_everywhere(app, client, web, participant):
    study_id = web.study(design="all_ordered", catch=2, extra=SCREENING)
    slug = study_slug(app, study_id)
    for catch_answer in ("undecided", "left"):  # the second fails the first check: stopped
        participant.client = app.test_client()
        _answer_before(participant, participant.join(slug))
        while (trial := participant.current_trial()) is not None:
            with app.app_context():
                kind = db.session.get(Trial, trial).kind
            participant.vote(trial, catch_answer if kind == "catch" else "left")
    web.login(client)
    base = f"/experimenter/studies/{study_id}"
    monitor = client.get(f"{base}/monitor").get_data(as_text=True)
    rows = {m[0]: m[1] for m in re.findall(r'id="participant-(P\d+)" data-status="(\w+)"', monitor)}
    assert rows == {"P0000": "finished", "P0001": "screened_out"}
    assert re.search(r'id="stat-screened_out">1<', monitor)
    assert "no: failed attention checks" in monitor
    votes = {r["participant"]: r for r in _csv(client, f"{base}/votes.csv")}
    assert (votes["P0001"]["status"], votes["P0001"]["excluded"]) == (
        "screened_out",
        "failed attention checks",
    )
    answers = {r["participant"]: r["status"] for r in _csv(client, f"{base}/answers.csv")}
    assert answers == {"P0000": "finished", "P0001": "screened_out"}
    people = {r["participant"]: r for r in _csv(client, f"{base}/participants.csv")}
    assert people["P0001"]["status"] == "screened_out"
    assert people["P0001"]["excluded"] == "failed attention checks"
    token = web.csrf(client, base)
    client.post(f"{base}/status/close", data={"csrf_token": token})
    report = client.get(f"{base}/report/")
    html = report.get_data(as_text=True)
    report.close()
    assert "P0001: failed attention checks" in html and "did not finish" not in html


def test_participants_export_has_a_pilot_column(app, client, web, participant):
    study_id = web.study(design="all_ordered", status="ready")
    with app.app_context():
        pilot_token = db.session.get(Study, study_id).pilot_token
    web.login(client)
    participant.client = app.test_client()
    participant.join_pilot(pilot_token)
    base = f"/experimenter/studies/{study_id}"
    token = web.csrf(client, base)
    client.post(f"{base}/status/open", data={"csrf_token": token})
    participant.client = app.test_client()
    participant.join(study_slug(app, study_id))
    people = _csv(client, f"{base}/participants.csv")
    assert [(r["participant"], r["pilot"]) for r in people] == [
        ("P0000", "true"),
        ("P0001", "false"),
    ]
    assert [r["excluded"] for r in people] == ["pilot", "did not finish"]


def _take_out(client, study_id, label, how, reason=""):
    base = f"/experimenter/studies/{study_id}"
    token = re.search(
        r'name="csrf_token" value="([^"]+)"', client.get(f"{base}/monitor").get_data(as_text=True)
    )
    return client.post(
        f"{base}/participants/{'restore' if how == 'restore' else 'exclude'}",
        data={"csrf_token": token.group(1), "participant": label, "how": how, "reason": reason},
    )


def test_an_exclusion_is_undone_and_the_slot_taken_again(app, client, web, participant):
    study_id = web.study(design="all_ordered")
    _run(app, participant, study_slug(app, study_id), catch_answer="undecided", pid="pid-a")
    web.login(client)
    assigned = sa.select(sa.func.sum(StudyList.n_assigned))
    _take_out(client, study_id, "P0000", "excluded", "spoke to a neighbour")
    with app.app_context():
        assert db.session.scalar(assigned) == 0
    assert _take_out(client, study_id, "P0000", "restore").status_code == 302
    with app.app_context():
        person = db.session.scalar(sa.select(Participant))
        taken_out = (person.excluded_at, person.exclusion_kind, person.exclusion_reason)
        assert taken_out == (None, "", "")
        assert person.dropped_at is None and db.session.scalar(assigned) == 1
    monitor = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    assert 'data-status="finished"' in monitor and "restore-P0000" not in monitor
    # Undoing twice changes nothing: the slot is taken once.
    _take_out(client, study_id, "P0000", "restore")
    with app.app_context():
        assert db.session.scalar(assigned) == 1


def test_the_note_on_a_returned_submission_is_kept(app, client, web, participant):
    study_id = web.study(design="all_ordered")
    _run(app, participant, study_slug(app, study_id), catch_answer="undecided", pid="pid-b")
    web.login(client)
    _take_out(client, study_id, "P0000", "returned", "  asked to return:  no sound ")
    base = f"/experimenter/studies/{study_id}"
    monitor = client.get(f"{base}/monitor").get_data(as_text=True)
    assert 'data-status="returned"' in monitor and "asked to return: no sound" in monitor
    assert 'id="restore-P0000"' in monitor
    why = "returned the submission on Prolific: asked to return: no sound"
    assert {(r["status"], r["excluded"]) for r in _csv(client, f"{base}/votes.csv")} == {
        ("returned", why)
    }
    assert _csv(client, f"{base}/participants.csv")[0]["excluded"] == why
