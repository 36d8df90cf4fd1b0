import threading

import pytest
import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.web.extensions import db
from app.web.models import Participant, Study, Trial, Vote


def _join(app, participant, web, **toml):
    study_id = web.study(**toml)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    return participant.join(slug)


def _votes(app):
    with app.app_context():
        return db.session.scalars(sa.select(Vote).order_by(Vote.id)).all()


def test_vote_is_idempotent(app, participant, web):
    _join(app, participant, web)
    trial = participant.current_trial()
    first = participant.vote(trial, "left", key="same-key-123")
    again = participant.vote(trial, "left", key="same-key-123")
    assert (first.status_code, again.status_code) == (201, 200)
    assert first.json["status"] == "recorded" and again.json["status"] == "duplicate"
    # A second vote with another key on an answered trial keeps the first answer.
    other = participant.vote(trial, "right", key="other-key-456")
    assert other.status_code == 200 and other.json["vote"]["choice"] == "left"
    votes = _votes(app)
    assert [(v.trial_id, v.choice, v.idempotency_key) for v in votes] == [
        (trial, "left", "same-key-123")
    ]
    assert votes[0].response_ms == 1234 and votes[0].plays == 1
    assert votes[0].presented_at.isoformat() == "2026-01-01T10:00:00"


def test_concurrent_duplicates_store_one_vote(app, participant, web):
    token = _join(app, participant, web)
    trial = participant.current_trial()
    results = []

    def post():
        client = app.test_client()
        response = client.post(
            "/api/v1/votes",
            json={
                "token": token,
                "trial_id": trial,
                "choice": "right",
                "plays": 1,
                "watched_to_end": True,
                "idempotency_key": "racing-key-1",
            },
        )
        results.append(response.status_code)

    threads = [threading.Thread(target=post) for _ in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(results) == [200] * 5 + [201]
    assert len(_votes(app)) == 1


def test_key_reused_on_another_trial_is_refused(app, participant, web):
    token = _join(app, participant, web, design="all_ordered")
    with app.app_context():
        trials = db.session.scalars(
            sa.select(Trial)
            .join(Participant)
            .where(Participant.token == token, Trial.kind == "trial")
            .order_by(Trial.position)
        ).all()
        ids = [t.id for t in trials]
    assert participant.vote(ids[0], key="key-abcdefgh").status_code == 201
    assert participant.vote(ids[1], key="key-abcdefgh").status_code == 409


def test_bad_votes_are_refused_with_a_reason(app, participant, web):
    token = _join(app, participant, web, undecided=False, replay="max_plays", max_plays=2)
    trial = participant.current_trial()
    assert participant.vote(trial, "undecided").status_code == 400
    assert participant.vote(trial, "sideways").status_code == 400
    assert participant.vote(trial, "left", plays=0).status_code == 422
    assert participant.vote(trial, "left", plays=3).json["error"].startswith("plays")
    assert participant.vote(trial, "left", key="short").status_code == 400
    assert participant.vote(trial, "left", presented_at="yesterday").status_code == 400
    assert participant.client.post("/api/v1/votes", data="x").status_code == 400
    bad_token = participant.client.post("/api/v1/votes", json={"token": "nope", "trial_id": 1})
    assert bad_token.status_code == 403
    with app.app_context():
        practice = db.session.scalar(
            sa.select(Trial.id)
            .join(Participant)
            .where(Participant.token == token, Trial.kind == "practice")
        )
    assert participant.vote(practice).status_code == 422
    assert _votes(app) == []
    assert participant.vote(trial, "left", plays=2).status_code == 201


def test_play_to_end_policy(app, participant, web):
    _join(app, participant, web, replay="play_to_end")
    trial = participant.current_trial()
    assert participant.vote(trial, watched_to_end=False).status_code == 422
    assert participant.vote(trial, watched_to_end=True).status_code == 201


def test_progress_endpoint(app, client, participant, web):
    token = _join(app, participant, web)
    start = client.get(f"/api/v1/participants/{token}/progress").json
    assert start == {"answered": 0, "total": start["total"], "finished": False}
    while (trial := participant.current_trial()) is not None:
        participant.vote(trial)
    end = client.get(f"/api/v1/participants/{token}/progress").json
    assert end == {"answered": start["total"], "total": start["total"], "finished": True}
    assert client.get("/api/v1/participants/unknown/progress").status_code == 404


def test_job_status_needs_the_owner(app, client, web):
    from app.web.models import Job

    study_id = web.study()
    with app.app_context():
        job = Job(study_id=study_id, kind="render", done=1, total=4)
        db.session.add(job)
        db.session.commit()
        job_id = job.id
    assert client.get(f"/api/v1/jobs/{job_id}").status_code == 401
    web.login(client)
    body = client.get(f"/api/v1/jobs/{job_id}").json
    assert body["fraction"] == 0.25 and body["status"] == "queued"
    web.user("other@example.org")
    other = app.test_client()
    web.login(other, "other@example.org")
    assert other.get(f"/api/v1/jobs/{job_id}").status_code == 404


def test_a_vote_on_a_closed_study_says_so_for_good(app, participant, web):
    token = _join(app, participant, web)
    trial = participant.current_trial()
    with app.app_context():
        db.session.scalar(
            sa.select(Participant).where(Participant.token == token)
        ).study.status = "closed"
        db.session.commit()
    response = participant.vote(trial)
    assert response.status_code == 409
    # ``error`` for scripts; ``message`` for the participant, in the study's language.
    assert response.json == {
        "error": "this study is closed",
        "message": "This study is closed. Thank you for taking part.",
        "closed": True,
    }
    assert _votes(app) == []


@pytest.mark.parametrize(
    "url",
    [
        "sqlite:////nonexistent-folder/facepair.sqlite",
        "postgresql+psycopg://postgres@127.0.0.1:9/nowhere",
    ],
)
def test_database_unreachable_is_503_with_retry_after(tmp_path, url):
    from app.web import create_app

    app = create_app(
        {
            "TESTING": True,
            "SQLALCHEMY_DATABASE_URI": url,
            "MEDIA_ROOT": str(tmp_path),
            "RETRY_AFTER_SECONDS": 7,
        }
    )
    client = app.test_client()
    vote = client.post("/api/v1/votes", json={"token": "t" * 32, "trial_id": 1})
    assert vote.status_code == 503 and vote.headers["Retry-After"] == "7"
    assert vote.json["error"].startswith("the database is unavailable")
    page = client.get("/p/some-token/trial")
    assert page.status_code == 503 and page.headers["Retry-After"] == "7"
    assert "Please try again in a moment" in page.get_data(as_text=True)
    assert client.get("/healthz").status_code == 503


# --- the media log, the environment and the play requests -----------------------------------

MEDIA = {
    "watched_ms": 4100,
    "played_to_end": True,
    "stalls": 2,
    "stall_ms": 950,
    "focus_lost": 1,
    "pauses": 1,
    "seeks": 0,
    "width": 640,
    "height": 320,
    "stall_durations": [700, 250],
}


def test_the_media_log_is_stored_and_exported(app, participant, web):
    from app.web.study.exports import votes_csv

    _join(app, participant, web)
    trial = participant.current_trial()
    assert participant.vote(trial, "left", media=MEDIA).status_code == 201
    with app.app_context():
        vote = db.session.scalar(sa.select(Vote))
        assert (
            vote.watched_ms,
            vote.played_to_end,
            vote.stalls,
            vote.stall_ms,
            vote.focus_lost,
        ) == (4100, True, 2, 950, 1)
        assert vote.media == {
            "pauses": 1,
            "seeks": 0,
            "width": 640,
            "height": 320,
            "stall_durations": [700, 250],
        }
        text = votes_csv(db.session.scalars(sa.select(Study)).one())
    header, row = text.splitlines()[:2]
    values = dict(zip(header.split(","), row.split(","), strict=True))
    assert {
        k: values[k] for k in ("watched_ms", "played_to_end", "stalls", "stall_ms", "focus_lost")
    } == {
        "watched_ms": "4100",
        "played_to_end": "true",
        "stalls": "2",
        "stall_ms": "950",
        "focus_lost": "1",
    }


@pytest.mark.parametrize(
    ("media", "message"),
    [
        ("lots", "media: expected an object"),
        ({"stalls": -1}, "stalls: expected a whole number"),
        ({"played_to_end": "yes"}, "played_to_end: expected true or false"),
        ({"stall_durations": "x"}, "stall_durations: expected a list"),
    ],
)
def test_a_bad_media_log_is_refused_with_its_field(app, participant, web, media, message):
    _join(app, participant, web)
    response = participant.vote(participant.current_trial(), "left", media=media)
    assert response.status_code == 400 and response.json["error"].startswith(message)


def test_environment_and_viewing_check(app, client, participant, web):
    token = _join(app, participant, web, extra="\n[viewing]\nmin_face_px = 200\n")
    chrome = (
        "Mozilla/5.0 (Linux; Android 14) AppleWebKit/537.36 (KHTML, like Gecko) "
        "Chrome/126.0.0.0 Mobile Safari/537.36"
    )
    report = {
        "screen_w": 390,
        "screen_h": 844,
        "viewport_w": 390,
        "viewport_h": 700,
        "dpr": 3,
        "touch": True,
        "face_px": 180,
    }
    answer = client.post(
        f"/api/v1/participants/{token}/environment", json=report, headers={"User-Agent": chrome}
    )
    assert answer.status_code == 200 and answer.json == {"viewing_ok": False}
    blocked = client.get(f"/p/{token}/trial")
    assert blocked.status_code == 409 and b"at least 200 pixels" in blocked.data
    wide = client.post(
        f"/api/v1/participants/{token}/environment",
        json=report | {"face_px": 320},
        headers={"User-Agent": chrome},
    )
    assert wide.json == {"viewing_ok": True}
    assert client.get(f"/p/{token}/trial").status_code == 200
    with app.app_context():
        env = db.session.scalar(sa.select(Participant)).environment
    assert (env["browser"], env["browser_version"], env["dpr"], env["touch"]) == (
        "Chrome",
        "126",
        3,
        True,
    )


JSONISH = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner, max_size=3)
    ),
    max_leaves=8,
)


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(media=JSONISH, env=JSONISH, strength=JSONISH, reasons=JSONISH, trial=JSONISH)
def test_hostile_participant_side_bodies_never_5xx(
    app, client, participant, web, media, env, strength, reasons, trial
):
    if participant.token is None:
        _join(app, participant, web, extra='\n[answer]\nscale = 5\nreasons = ["a"]\n')
    trial_id = participant.current_trial()
    responses = [
        participant.vote(trial_id, "left", media=media, strength=strength, reasons=reasons),
        client.post(f"/api/v1/participants/{participant.token}/environment", json=env),
        client.post("/api/v1/plays", json={"token": participant.token, "trial_id": trial}),
    ]
    for response in responses:
        assert response.status_code < 500, response.get_data(as_text=True)
        assert "Traceback" not in response.get_data(as_text=True)


def _vote_body(participant, trial_id: int, key: str) -> dict:
    return {
        "token": participant.token,
        "trial_id": trial_id,
        "choice": "left",
        "plays": 1,
        "watched_to_end": True,
        "response_ms": 900,
        "idempotency_key": key,
    }


def test_a_vote_body_is_read_with_or_without_a_length(app, participant, web):
    import io
    import json

    _join(app, participant, web)
    trial = participant.current_trial()
    body = json.dumps(_vote_body(participant, trial, "chunked-body-01")).encode()
    # Chunked: no Content-Length, so werkzeug's guarded stream reads it (from a server that
    # ends the stream itself, as gunicorn does).
    chunked = participant.client.post(
        "/api/v1/votes",
        input_stream=io.BytesIO(body),
        headers={"Content-Type": "application/json", "Transfer-Encoding": "chunked"},
        environ_overrides={"wsgi.input_terminated": True},
    )
    assert chunked.status_code == 201, chunked.get_data(as_text=True)
    assert [v.idempotency_key for v in _votes(app)] == ["chunked-body-01"]
    again = participant.client.post("/api/v1/votes", data=body, content_type="application/json")
    assert again.status_code == 200 and again.json["status"] == "duplicate"


@pytest.mark.parametrize(
    ("body", "content_type", "message"),
    [
        (b'{"token": "x"', "application/json", "body: expected a JSON object"),
        (b"\xff\xfe\xfa", "application/json", "body: expected a JSON object"),
        (b"[1, 2]", "application/json", "body: expected a JSON object"),
        (b'{"token": "x"}', "text/plain", "body: expected a JSON object"),
        (b"[" * 100_000 + b"]" * 100_000, "application/json", "body: larger than 64 KB"),
        (b"[" * 20_000 + b"]" * 20_000, "application/json", "body: JSON nested too deeply"),
    ],
    ids=["truncated", "not-utf8", "array", "not-json-type", "too-large", "too-deep"],
)
def test_a_body_that_is_no_json_object_is_a_400_naming_why(
    app, participant, web, body, content_type, message
):
    _join(app, participant, web)
    for path in ("/api/v1/votes", "/api/v1/plays"):
        answer = participant.client.post(path, data=body, content_type=content_type)
        assert answer.status_code in (400, 413), (path, answer.status_code)
        if answer.status_code == 400:
            assert answer.json["error"] == message, (path, answer.json)
    assert _votes(app) == []


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(body=st.binary(max_size=300), chunked=st.booleans())
def test_raw_vote_bodies_never_5xx(app, participant, web, body, chunked):
    import io

    if participant.token is None:
        _join(app, participant, web)
    for path in ("/api/v1/votes", "/api/v1/plays"):
        if chunked:  # no Content-Length: werkzeug reads it
            answer = participant.client.post(
                path,
                input_stream=io.BytesIO(body),
                headers={"Content-Type": "application/json", "Transfer-Encoding": "chunked"},
                environ_overrides={"wsgi.input_terminated": True},
            )
        else:  # with its length: read straight from the stream
            answer = participant.client.post(path, data=body, content_type="application/json")
        assert answer.status_code < 500, answer.get_data(as_text=True)
        assert "Traceback" not in answer.get_data(as_text=True)


@pytest.mark.parametrize(
    ("token", "root"),
    [("Ab_9-x.y~z", ""), ("Ab_9", "/under/a/proxy"), ("a b/c", ""), ("x", "/~token~")],
)
def test_the_participant_urls_of_a_vote_answer_are_url_fors(app, token, root):
    from flask import url_for

    from app.web.api.views import _participant_urls

    for _ in range(2):  # built, then from the routes kept for this script root
        with app.test_request_context("/api/v1/votes", base_url=f"http://h{root}"):
            resume, video, webm = _participant_urls(token)
            assert resume == url_for("participant.resume", token=token)
            assert f"{video}12" == url_for("participant.video", token=token, trial_id=12)
            assert f"{webm}12" == url_for("participant.video_webm", token=token, trial_id=12)
