"""The audio check before the first trial (``app.web.participant.audio``,
``app.web.study.audiocheck``): the trial waits for it, the server keeps the answer key and
scores, a failed attempt may be repeated as the study file allows, and the result reaches
participants.csv and the analysis's exclusions."""

from __future__ import annotations

import csv
import io
import re

import sqlalchemy as sa
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from app.web.extensions import db
from app.web.models import Participant, Study
from app.web.study import audiocheck
from app.web.study.enrolment import dropped_after
from app.web.study.exports import vote_rows
from app.web.study.participants import participant_table
from app.web.study.privacy import participants_csv
from tests.conftest import csrf_token
from tests.support.studies import study_slug

HUGGINS = """[audio_check]
kind = "huggins"
"""
TWO_TRIES = """[audio_check]
kind = "antiphase"
trials = 3
pass_mark = 3
attempts = 2
"""


def _key(app, token: str, attempt: int) -> list[int]:
    """The answer key of ``attempt`` as the server holds it."""
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        spec = audiocheck.audio_spec(person)
        return audiocheck._targets(person.audio_check, attempt, spec.trials)


def _answer(client, token: str, attempt: int, question: int, choice) -> object:
    url = f"/p/{token}/audio-check"
    data = {"csrf_token": csrf_token(client, url), "attempt": attempt, "question": question}
    if choice is not None:
        data["choice"] = choice
    return client.post(url, data=data)


def _csv_row(app, study_id) -> dict[str, str]:
    with app.app_context():
        text = participants_csv(db.session.get(Study, study_id))
    return next(csv.DictReader(io.StringIO(text)))


def test_the_trial_waits_for_the_check_and_a_pass_opens_it(app, client, participant, web):
    study_id = web.study(extra=HUGGINS)
    token = participant.join(study_slug(app, study_id))
    first = client.get(f"/p/{token}/trial")
    assert first.status_code == 302 and first.headers["Location"].endswith("/audio-check")
    page = client.get(f"/p/{token}/audio-check").get_data(as_text=True)
    assert "Question 1 of 6" in page and "Which sound has a faint tone" in page
    sound = client.get(f"/p/{token}/audio-check/1-1.wav")
    assert sound.status_code == 200 and sound.mimetype == "audio/wav"
    assert sound.data[:4] == b"RIFF" and sound.headers["Cache-Control"] == "no-store"
    # Only the question asked has a sound: no later one, no other attempt.
    assert client.get(f"/p/{token}/audio-check/1-2.wav").status_code == 404
    assert client.get(f"/p/{token}/audio-check/2-1.wav").status_code == 404
    key = _key(app, token, 1)
    pages = []
    for number, target in enumerate(key, start=1):
        pages.append(client.get(f"/p/{token}/audio-check").get_data(as_text=True))
        answer = _answer(client, token, 1, number, target)
        assert answer.status_code in (200, 302)
    # Nothing on a question's page depends on its answer: after the first (which explains the
    # check), the pages differ only in numbers.
    shapes = {re.sub(r"\d+", "#", re.sub(r'name="csrf_token"[^>]*>', "", p)) for p in pages[1:]}
    assert len(shapes) == 1
    assert "Your sound works well" in answer.get_data(as_text=True)
    assert client.get(f"/p/{token}/trial").status_code == 200
    assert client.get(f"/p/{token}/audio-check").status_code == 302  # done: on to the trials
    row = _csv_row(app, study_id)
    assert (row["audio_check"], row["audio_check_attempts"], row["audio_check_score"]) == (
        "passed",
        "1",
        "6",
    )


def test_a_failed_check_may_be_repeated_then_excludes_the_participant(
    app, client, participant, web
):
    study_id = web.study(extra=TWO_TRIES)
    token = participant.join(study_slug(app, study_id))
    client.get(f"/p/{token}/audio-check")
    for attempt in (1, 2):
        key = _key(app, token, attempt)
        for number, target in enumerate(key, start=1):
            last = _answer(client, token, attempt, number, (target + 1) % 3)
        if attempt == 1:
            retry = client.get(f"/p/{token}/audio-check").get_data(as_text=True)
            assert "Not every answer was right" in retry and 'id="audio-retry"' in retry
            url = f"/p/{token}/audio-check"
            client.post(url, data={"csrf_token": csrf_token(client, url), "retry": "1"})
            assert "Question 1 of 3" in client.get(url).get_data(as_text=True)
    # Failed for good: thanked, and on to the trials all the same.
    assert "Thank you. The study begins now." in last.get_data(as_text=True)
    trial = participant.current_trial()
    assert trial is not None and participant.vote(trial).status_code == 201
    row = _csv_row(app, study_id)
    assert (row["audio_check"], row["audio_check_attempts"], row["audio_check_score"]) == (
        "failed",
        "2",
        "0",
    )
    with app.app_context():
        study = db.session.get(Study, study_id)
        (person,) = participant_table(study, dropped_after=dropped_after())
        assert person.audio_check == "failed"
        assert person.excluded == "failed the audio check"
        assert {r["excluded"] for r in vote_rows(study)} == {"failed the audio check"}


def test_no_vote_before_the_check(app, client, participant, web):
    """A vote sent without the trial page (its trial's id guessed) waits for the check too."""
    study_id = web.study(extra=HUGGINS)
    token = participant.join(study_slug(app, study_id))
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        trial = min(t.id for t in person.trials if t.kind != "practice")
    refused = participant.vote(trial)
    assert refused.status_code == 409
    assert refused.json["error"].startswith("audio_check: ")


def test_a_study_without_a_check_goes_straight_to_the_trials(app, client, participant, web):
    study_id = web.study()
    token = participant.join(study_slug(app, study_id))
    assert client.get(f"/p/{token}/trial").status_code == 200
    assert client.get(f"/p/{token}/audio-check").status_code == 302
    assert client.get(f"/p/{token}/audio-check/1-1.wav").status_code == 404
    assert _csv_row(app, study_id)["audio_check"] == ""


def test_a_resent_answer_counts_once(app, client, participant, web):
    token = participant.join(study_slug(app, web.study(extra=HUGGINS)))
    client.get(f"/p/{token}/audio-check")
    for _ in range(3):
        _answer(client, token, 1, 1, 0)
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        assert person.audio_check["answers"] == [[0]]


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    form=st.dictionaries(
        st.sampled_from(["attempt", "question", "choice", "retry"]),
        st.one_of(st.text(max_size=8), st.integers(-5, 5).map(str)),
    )
)
@example(form={"choice": "²", "question": "١"})  # digits to str.isdigit, not to int()
def test_any_answer_form_is_stored_or_refused_never_a_server_error(app, web, form):
    """Whatever the form holds: no response >= 500, and the check's state stays well formed
    (answers 0 to 2, at most the study's number per attempt)."""
    client = app.test_client()
    from tests.conftest import ParticipantActions

    token = ParticipantActions(client, app).join(study_slug(app, web.study(extra=TWO_TRIES)))
    url = f"/p/{token}/audio-check"
    response = client.post(url, data={"csrf_token": csrf_token(client, url), **form})
    assert response.status_code < 500
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        for answers in (person.audio_check or {}).get("answers", []):
            assert len(answers) <= 3 and set(answers) <= {0, 1, 2}
