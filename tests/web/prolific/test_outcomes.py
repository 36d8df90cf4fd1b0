"""Submission outcomes: the webhook (signature checked as Prolific documents it, events applied
once by X-Event-ID and in X-Timestamp order, HTTPS only) and polling; a RETURNED or TIMED-OUT
submission makes its participant ``returned``. Property-based: no delivery, however malformed,
gets a 5xx."""

from __future__ import annotations

import json
import time

import sqlalchemy as sa
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from app.web.extensions import db
from app.web.models import Participant
from app.web.prolific.client import client_from_environment
from app.web.prolific.models import ProlificEvent, ProlificStudy, ProlificSubmission
from app.web.prolific.outcomes import signature, sync
from tests.web.prolific.conftest import draft, take_part

URL = "/api/v1/prolific/webhook"


def _link(app, study_id: int, prolific_id: str) -> None:
    with app.app_context():
        db.session.add(ProlificStudy(study_id=study_id, prolific_id=prolific_id, status="ACTIVE"))
        db.session.commit()


def _post(client, headers, body, scheme="https"):
    return client.post(URL, data=body, headers=headers, base_url=f"{scheme}://localhost")


def _status(app, pid: str) -> tuple[str, str]:
    with app.app_context():
        person = db.session.scalars(
            sa.select(Participant).where(Participant.prolific_pid == pid)
        ).one()
        return person.exclusion_kind, person.exclusion_reason


def test_a_returned_submission_makes_the_participant_returned_once(
    app, client, prolific_env, recruiting_study
):
    fake = prolific_env
    _link(app, recruiting_study, "S1")
    sid, pid = fake.start("S1")
    take_part(app, recruiting_study, "S1", sid, pid, finish=False)
    headers, body = fake.event("submission.status.change", sid, "RETURNED", participant_id=pid)
    first = _post(client, headers, body)
    assert first.status_code == 200 and "returned" in first.json["status"]
    assert _status(app, pid) == ("returned", "Prolific: submission RETURNED")
    replay = _post(client, headers, body)
    assert replay.status_code == 200 and replay.json == {
        "status": "duplicate",
        "event": headers["X-Event-ID"],
    }
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(ProlificEvent.id))) == 1


def test_timed_out_is_returned_too_and_older_news_is_ignored(
    app, client, prolific_env, recruiting_study
):
    fake = prolific_env
    _link(app, recruiting_study, "S1")
    sid, pid = fake.start("S1")
    take_part(app, recruiting_study, "S1", sid, pid)
    now = time.time()
    late = fake.event("submission.status.change", sid, "APPROVED", participant_id=pid, sent_at=now)
    early = fake.event(
        "submission.status.change", sid, "AWAITING REVIEW", participant_id=pid, sent_at=now - 60
    )
    assert _post(client, *late).json["status"] == "applied: APPROVED"
    assert _post(client, *early).json["status"] == "older than the APPROVED known"
    with app.app_context():
        assert db.session.scalar(sa.select(ProlificSubmission.status)) == "APPROVED"
    sid2, pid2 = fake.start("S1")
    take_part(app, recruiting_study, "S1", sid2, pid2, finish=False)
    assert (
        "returned"
        in _post(client, *fake.event("submission.status.change", sid2, "TIMED-OUT")).json["status"]
    )
    assert _status(app, pid2) == ("returned", "Prolific: submission TIMED-OUT")


def test_bad_or_missing_signatures_and_plain_http_are_refused(
    app, client, prolific_env, recruiting_study
):
    fake = prolific_env
    headers, body = fake.event("submission.status.change", "X", "RETURNED", secret="not-the-secret")
    assert _post(client, headers, body).status_code == 401
    good_headers, good_body = fake.event("submission.status.change", "X", "RETURNED")
    tampered = good_body.replace(b"RETURNED", b"APPROVED")
    assert _post(client, good_headers, tampered).status_code == 401
    unsigned = {k: v for k, v in good_headers.items() if "Signature" not in k}
    assert _post(client, unsigned, good_body).status_code == 401
    stamp = str(int(time.time()) - 7200)
    stale = dict(good_headers, **{"X-Prolific-Request-Timestamp": stamp})
    stale["X-Prolific-Request-Signature"] = signature(fake.secret, stamp, good_body)
    assert _post(client, stale, good_body).json == {"error": "the signature is too old"}
    assert _post(client, good_headers, good_body, scheme="http").status_code == 403
    # switching HTTPS off is for a testing or debug application only, never production
    app.config.update(PROLIFIC_WEBHOOK_HTTPS_ONLY="false", TESTING=False)
    try:
        assert _post(client, good_headers, good_body, scheme="http").status_code == 403
    finally:
        app.config.update(PROLIFIC_WEBHOOK_HTTPS_ONLY=None, TESTING=True)
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(ProlificEvent.id))) == 0
    # Prolific's own example signs json.dumps of the parsed body: accepted as well
    compact = json.dumps(json.loads(good_body), separators=(",", ":")).encode()
    dumped = dict(good_headers)
    dumped["X-Prolific-Request-Signature"] = signature(
        fake.secret,
        dumped["X-Prolific-Request-Timestamp"],
        json.dumps(json.loads(compact)).encode(),
    )
    assert _post(client, dumped, compact).status_code == 200
    app.config["PROLIFIC_WEBHOOK_SECRET"] = None
    assert _post(client, good_headers, good_body).status_code == 404


def test_a_study_status_change_is_kept(app, client, prolific_env, recruiting_study):
    _link(app, recruiting_study, "S9")
    answer = _post(client, *prolific_env.event("study.status.change", "S9", "AWAITING REVIEW"))
    assert answer.json["status"] == "applied: study AWAITING REVIEW"
    with app.app_context():
        assert db.session.scalar(sa.select(ProlificStudy.status)) == "AWAITING REVIEW"


def test_polling_without_a_webhook(app, prolific_env, recruiting_study):
    fake = prolific_env
    made = _create(app)
    _link(app, recruiting_study, made)
    (s1, p1), (s2, p2) = fake.start(made), fake.start(made)
    take_part(app, recruiting_study, made, s1, p1)
    take_part(app, recruiting_study, made, s2, p2, finish=False)
    fake.submit(s1, "DONE-123")
    fake.set_status(s2, "TIMED-OUT")
    with app.app_context():
        from app.web.models import Study

        report = sync(db.session.get(Study, recruiting_study), client_from_environment(app.config))
        assert (report.submissions, report.returned) == (2, 1)
        statuses = dict(
            db.session.execute(
                sa.select(ProlificSubmission.submission_id, ProlificSubmission.status)
            ).all()
        )
    assert statuses == {s1: "AWAITING REVIEW", s2: "TIMED-OUT"}
    assert _status(app, p2)[0] == "returned" and _status(app, p1)[0] == ""


def _create(app) -> str:
    return (
        client_from_environment(app.config)
        .request("POST", "/api/v1/studies/", call="create", json=draft())
        .data["id"]
    )


HEADER_NAMES = st.sampled_from(
    [
        "X-Event-ID",
        "X-Timestamp",
        "X-Prolific-Request-Timestamp",
        "X-Prolific-Request-Signature",
        "Content-Type",
    ]
)
TEXT = st.text(st.characters(min_codepoint=32, max_codepoint=0x2FF), max_size=40)
JSONISH = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | TEXT,
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(TEXT, inner, max_size=4),
    max_leaves=12,
)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(headers=st.dictionaries(HEADER_NAMES, TEXT, max_size=5), body=st.binary(max_size=300))
# a signature with a non-ASCII character once reached hmac.compare_digest as text: a 500
@example(
    headers={"X-Prolific-Request-Timestamp": "1", "X-Prolific-Request-Signature": "\x80"},
    body=b"",
)
def test_no_delivery_gets_a_5xx(app, client, prolific_env, headers, body):
    answer = _post(client, headers, body)
    assert answer.status_code < 500 and answer.is_json


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    payload=st.dictionaries(
        st.sampled_from(["event_type", "resource_id", "status", "participant_id", "metadata"]),
        JSONISH,
        max_size=5,
    ),
    event_id=TEXT,
    sent_at=TEXT | st.floats(allow_nan=True).map(str),
)
def test_no_signed_delivery_gets_a_5xx(app, client, prolific_env, payload, event_id, sent_at):
    """Signed with the right secret (so it passes the door) and still malformed: 4xx or
    applied, never a traceback."""
    body = json.dumps(payload).encode()
    stamp = str(int(time.time()))
    headers = {
        "X-Event-ID": event_id,
        "X-Timestamp": sent_at,
        "X-Prolific-Request-Timestamp": stamp,
        "X-Prolific-Request-Signature": signature(prolific_env.secret, stamp, body),
    }
    answer = _post(client, headers, body)
    assert answer.status_code < 500 and answer.is_json
