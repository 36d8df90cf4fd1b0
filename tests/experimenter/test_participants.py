"""The monitor's participant table, exclusion by hand, and the statuses the export carries."""

import csv
import io
import re

import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study, StudyList, Trial


def _slug(app, study_id):
    with app.app_context():
        return db.session.get(Study, study_id).slug


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
    slug = _slug(app, study_id)
    _run(app, participant, slug, catch_answer="undecided", pid="5f0000000000000000000001")
    _run(app, participant, slug, catch_answer="left", pid="5f0000000000000000000002")
    participant.client = app.test_client()
    participant.join(slug)  # started, never voted
    web.login(client)
    monitor = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    rows = {m[0]: m[1] for m in re.findall(r'id="participant-(P\d+)" data-status="(\w+)"', monitor)}
    assert rows == {"P0000": "finished", "P0001": "finished", "P0002": "started"}
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
    slug = _slug(app, study_id)
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
    participant.join(_slug(app, study_id))
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
