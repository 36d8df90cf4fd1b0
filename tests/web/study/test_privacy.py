"""Participants' personal data: the participants export names nobody unless the raw Prolific
IDs are asked for, and one participant's data can be deleted on request."""

import csv
import hashlib
import hmac
import io
import re

import pytest
import sqlalchemy as sa
from hypothesis import given, settings
from hypothesis import strategies as st

from app.web.extensions import db
from app.web.models import Participant, Study, StudyList, Trial, Vote
from app.web.study.labels import pseudonym
from tests.support.studies import study_slug

PID = "5f2a0c7e9b1d3e4f5a6b7c8d"


def _join(app, slug: str, pid: str, votes: int = 1):
    from tests.conftest import ParticipantActions

    person = ParticipantActions(app.test_client(), app)
    person.join(slug, f"PROLIFIC_PID={pid}&STUDY_ID=study-xyz&SESSION_ID=session-{pid}")
    for _ in range(votes):
        trial = person.current_trial()
        if trial is not None:
            assert person.vote(trial).status_code == 201
    return person


def _csv(response) -> list[dict[str, str]]:
    assert response.status_code == 200, response.status_code
    return list(csv.DictReader(io.StringIO(response.get_data(as_text=True))))


def test_the_pseudonym_is_a_keyed_hash():
    expected = hmac.new(b"key", PID.encode(), hashlib.sha256).hexdigest()[:16]
    assert pseudonym("key", PID) == f"anon-{expected}"


@given(st.text(max_size=80), st.text(min_size=1, max_size=80), st.text(min_size=1, max_size=80))
@settings(max_examples=300, deadline=None)
def test_pseudonyms_are_stable_distinct_and_name_nobody(key, first, second):
    value = pseudonym(key, first)
    assert re.fullmatch(r"anon-[0-9a-f]{16}", value)
    assert value == pseudonym(key, first)
    if first != second:
        assert value != pseudonym(key, second)


def test_exports_are_pseudonymised_unless_raw_ids_are_asked_for(app, client, web):
    study_id = web.study(design="all_ordered")
    slug = study_slug(app, study_id)
    _join(app, slug, PID, votes=4)
    _join(app, slug, "60aa11bb22cc33dd44ee55ff", votes=2)
    web.login(client)
    url = f"/experimenter/studies/{study_id}/participants.csv"
    default = client.get(url)
    text = default.get_data(as_text=True)
    assert PID not in text and "session-" not in text
    rows = _csv(default)
    with app.app_context():
        key = db.session.get(Study, study_id).pseudonym_key
    assert [r["participant"] for r in rows] == ["P0000", "P0001"]
    assert rows[0]["prolific_pid"] == pseudonym(key, PID)
    assert rows[0]["prolific_study_id"] == "study-xyz"  # Prolific's study, not a person
    assert [r["status"] for r in rows] == ["finished", "in_progress"]
    assert [r["answered"] for r in rows] == ["4", "2"]
    assert PID not in client.get(f"/experimenter/studies/{study_id}/votes.csv").get_data(
        as_text=True
    )
    raw = _csv(client.get(url + "?ids=raw"))
    assert raw[0]["prolific_pid"] == PID and raw[0]["prolific_session_id"] == f"session-{PID}"
    # Pseudonyms link exports of one study, never two studies.
    other = web.study(design="all_ordered")
    _join(app, study_slug(app, other), PID)
    again = _csv(client.get(f"/experimenter/studies/{other}/participants.csv"))
    assert again[0]["prolific_pid"] != rows[0]["prolific_pid"]
    assert _csv(client.get(url))[0]["prolific_pid"] == rows[0]["prolific_pid"]


def test_only_the_owner_gets_the_participants(app, client, web):
    study_id = web.study()
    _join(app, study_slug(app, study_id), PID)
    web.user("other@example.org")
    web.login(client, "other@example.org")
    url = f"/experimenter/studies/{study_id}/participants.csv"
    assert client.get(url).status_code == 404
    assert client.get(url + "?ids=raw").status_code == 404


def _delete(client, web, study_id: int, who: str, confirm: bool = True):
    page = f"/experimenter/studies/{study_id}"
    data = {"csrf_token": web.csrf(client, page), "participant": who}
    if confirm:
        data["confirm"] = "y"
    return client.post(f"{page}/participants/delete", data=data, follow_redirects=True)


def _counts(app, study_id: int) -> tuple[int, int, int, int]:
    with app.app_context():
        people = db.session.scalars(
            sa.select(Participant.id).where(Participant.study_id == study_id)
        ).all()
        votes = db.session.scalar(
            sa.select(sa.func.count(Vote.id)).where(Vote.participant_id.in_(people))
        )
        trials = db.session.scalar(
            sa.select(sa.func.count(Trial.id)).where(Trial.participant_id.in_(people))
        )
        slots = db.session.scalar(
            sa.select(sa.func.sum(StudyList.n_assigned)).where(StudyList.study_id == study_id)
        )
        return len(people), votes, trials, slots


def test_deleting_one_participant_on_request(app, client, web):
    study_id = web.study(design="all_ordered")
    slug = study_slug(app, study_id)
    _join(app, slug, PID, votes=3)
    _join(app, slug, "60aa11bb22cc33dd44ee55ff", votes=2)
    assert _counts(app, study_id) == (2, 5, 10, 2)  # 4 trials + the practice each
    web.login(client)
    page = _delete(client, web, study_id, PID).get_data(as_text=True)
    assert "Deleted P0000: 3 votes" in page
    assert _counts(app, study_id) == (1, 2, 5, 1)  # their slot is free for a new arrival
    export = client.get(f"/experimenter/studies/{study_id}/participants.csv?ids=raw")
    assert PID not in export.get_data(as_text=True)
    votes = client.get(f"/experimenter/studies/{study_id}/votes.csv").get_data(as_text=True)
    assert "P0000" not in votes and votes.count("P0001") == 2


def test_deleting_by_label_or_pseudonym(app, client, web):
    study_id = web.study(design="all_ordered")
    slug = study_slug(app, study_id)
    _join(app, slug, PID)
    _join(app, slug, "60aa11bb22cc33dd44ee55ff")
    web.login(client)
    with app.app_context():
        key = db.session.get(Study, study_id).pseudonym_key
    assert "Deleted P0001" in _delete(client, web, study_id, "P0001").get_data(as_text=True)
    page = _delete(client, web, study_id, pseudonym(key, PID)).get_data(as_text=True)
    assert "Deleted P0000" in page
    assert _counts(app, study_id)[:3] == (0, 0, 0)


def test_nothing_is_deleted_without_a_match_or_confirmation(app, client, web):
    study_id = web.study()
    _join(app, study_slug(app, study_id), PID)
    web.login(client)
    assert "Nothing deleted: no participant" in _delete(client, web, study_id, "P0042").get_data(
        as_text=True
    )
    assert "Nothing deleted (confirm" in _delete(
        client, web, study_id, PID, confirm=False
    ).get_data(as_text=True)
    assert "Nothing deleted (participant" in _delete(client, web, study_id, "x" * 201).get_data(
        as_text=True
    )
    assert _counts(app, study_id)[0] == 1


def test_a_deletion_removes_the_report_computed_with_their_votes(app, client, web):
    from app.web.infra.storage import report_path

    study_id = web.study()
    _join(app, study_slug(app, study_id), PID)
    web.login(client)
    with app.app_context():
        path = report_path(db.session.get(Study, study_id))
    path.parent.mkdir(parents=True)
    (path.parent / "votes.csv").write_text("participant\nP0000\n")
    path.write_text("<html></html>")
    _delete(client, web, study_id, PID)
    assert not path.parent.exists()


@pytest.mark.slow
def test_the_personal_data_routes_never_answer_5xx(app, web):
    from hypothesis import HealthCheck

    study_id = web.study()
    _join(app, study_slug(app, study_id), PID)
    client = app.test_client()
    web.login(client)
    page = f"/experimenter/studies/{study_id}"
    token = web.csrf(client, page)
    text = st.text(st.characters(blacklist_categories=("Cs",)), max_size=300)

    @settings(
        max_examples=300,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(
        who=st.one_of(text, st.just(PID), st.from_regex(r"[Pp]0*\d{1,12}", fullmatch=True)),
        ids=text,
    )
    def hostile(who, ids):
        deleted = client.post(
            f"{page}/participants/delete", data={"csrf_token": token, "participant": who}
        )
        assert deleted.status_code == 302, deleted.get_data(as_text=True)
        export = client.get(f"{page}/participants.csv", query_string={"ids": ids})
        assert export.status_code == 200

    hostile()
    assert _counts(app, study_id)[0] == 1  # never confirmed, so nothing was deleted


def test_a_rating_participant_has_answered_the_trials_they_rated(app, client, web):
    """``answered`` counts a rating study's answers too: the trials rated (a parallel page
    rates every version of its clip: one trial), with the checks rated and passed."""
    from tests.conftest import ParticipantActions
    from tests.support.rating import PARALLEL, rate_trial

    rating = web.study(design="rating", catch_kind="instructed", catch=1)
    person = ParticipantActions(app.test_client(), app)
    token = person.join(study_slug(app, rating))
    while (trial := person.current_trial()) is not None:
        with app.app_context():
            check = db.session.get(Trial, trial).kind == "catch"
        assert rate_trial(person.client, token, trial, 1 if check else 4).status_code == 201
    parallel = web.study(design="parallel", extra=PARALLEL)
    person = ParticipantActions(app.test_client(), app)
    token = person.join(study_slug(app, parallel))
    page = {"token": token, "trial_id": person.current_trial(), "scores": [90, 40], "plays": 2}
    page["idempotency_key"] = "parallel-answered-1"
    assert person.client.post("/api/v1/ratings", json=page).status_code == 201
    web.login(client)
    with app.app_context():
        trials = db.session.scalar(
            sa.select(sa.func.count(Trial.id)).where(Trial.kind != "practice")
            .join(Participant).where(Participant.study_id == rating)
        )  # fmt: skip
    (rated,) = _csv(client.get(f"/experimenter/studies/{rating}/participants.csv"))
    assert (rated["status"], rated["answered"]) == ("finished", str(trials))
    assert (rated["catch_passed"], rated["catch_total"]) == ("1", "1")
    (side_by_side,) = _csv(client.get(f"/experimenter/studies/{parallel}/participants.csv"))
    assert (side_by_side["status"], side_by_side["answered"]) == ("finished", "1")


def test_deleting_a_rating_participant_on_request(app, client, participant, web):
    """A rating study's participant is deleted with their ratings (their trials cannot go
    while ratings name them), and the message counts ratings."""
    from app.web.models import Rating
    from tests.support.rating import parallel_participants

    study_id = parallel_participants(app, client, participant, web, (95, 95))
    web.login(client)
    page = _delete(client, web, study_id, "P0000").get_data(as_text=True)
    assert "Deleted P0000: 2 ratings" in page
    with app.app_context():
        left = db.session.scalars(sa.select(Rating.participant_id).distinct()).all()
        assert len(left) == 1 and _counts(app, study_id)[:3] == (1, 0, 1)
    export = client.get(f"/experimenter/studies/{study_id}/ratings.csv").get_data(as_text=True)
    assert "P0000" not in export and export.count("P0001") == 2
