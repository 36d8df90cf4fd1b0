"""A participant's way through their schedule (``app.web.study.progress``): the next trials
without an answer in schedule order, the practice never among them, the counts (a parallel
trial once, however many versions it rated), and the next trial an answer carries."""

from __future__ import annotations

from types import SimpleNamespace

import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study, utcnow
from app.web.study.progress import next_trial, next_trial_of, next_trials, progress


def _person(app, participant, web, **toml) -> str:
    with app.app_context():
        slug = db.session.get(Study, web.study(**toml)).slug
    return participant.join(slug)


def _row(token: str) -> Participant:
    return db.session.scalar(sa.select(Participant).where(Participant.token == token))


def test_the_next_trials_are_the_unanswered_ones_in_schedule_order(app, participant, web):
    token = _person(app, participant, web, design="all_ordered", catch=1)
    with app.app_context():
        person = _row(token)
        schedule = [
            t.id for t in sorted(person.trials, key=lambda t: t.position) if t.kind != "practice"
        ]
        assert [t.id for t in next_trials(person, 10)] == schedule
        assert progress(person) == (0, len(schedule))
    participant.vote(schedule[0])
    participant.vote(schedule[2])  # out of order: the second stays next
    with app.app_context():
        person = _row(token)
        assert next_trial(person).id == schedule[1]
        assert [t.id for t in next_trials(person, 2)] == [schedule[1], schedule[3]]
        assert progress(person) == (2, len(schedule))


def test_a_parallel_trial_counts_once_for_all_its_versions(app, client, participant, web):
    token = _person(app, participant, web, design="parallel", extra='reference = "none"\n')
    trial = participant.current_trial()
    payload = {"token": token, "trial_id": trial, "scores": [70, 30], "plays": 3}
    answer = client.post("/api/v1/ratings", json={**payload, "idempotency_key": "progress-1"})
    assert answer.status_code == 201, answer.get_json()
    with app.app_context():
        person = _row(token)
        assert progress(person) == (1, 1) and next_trial(person) is None


def test_the_next_trial_an_answer_carries(app, participant, web):
    row = SimpleNamespace(
        trial_id=7,
        plays=1,
        kind="catch",
        expected="left",
        instruction=None,
        following=8,
        webm="pair-02.webm",
        following_webm=None,
    )
    token = _person(app, participant, web)
    with app.app_context():
        person = _row(token)
        shown = next_trial_of(row, person, 1, 3)
        assert (shown.trial_id, shown.kind, shown.following) == (7, "catch", 8)
        # whether each clip has its WebM rendition: this one has, the next one not (yet)
        assert (shown.webm, shown.following_webm) == (True, False)
        unloaded = next_trial_of(row, person, 1, 3, preload=False)
        assert unloaded.following is None and unloaded.following_webm is False
        assert next_trial_of(row, person, 3, 3) is None  # every trial answered
        assert next_trial_of(SimpleNamespace(trial_id=None), person, 1, 3) is None
        person.screened_out_at = utcnow()
        assert next_trial_of(row, person, 1, 3) is None  # screened out: the page decides
        db.session.rollback()
