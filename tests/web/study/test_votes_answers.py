"""The one vote path (``app.web.study.votes.record_vote``) as a participant's browser meets
it: refusals, the vote that finishes a schedule, the next pair the answer carries, and a vote
that waited for another of the same participant's; the same on SQLite and PostgreSQL."""

import re
import threading
import time

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study, StudyList, Trial, Vote
from tests.conftest import ParticipantActions


@pytest.fixture
def joined(app, participant, web):
    study_id = web.study(design="all_ordered")  # several trials
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    participant.join(slug)
    return participant


def test_another_participants_trial_and_a_closed_study_are_refused(app, client, joined, web):

    theirs = joined.current_trial()
    with app.app_context():
        slug = db.session.scalar(sa.select(Study.slug))
    other = ParticipantActions(app.test_client(), app)
    other.join(slug)
    refused = other.vote(theirs, "left")
    assert refused.status_code == 404 and refused.json["error"] == "no such trial"
    with app.app_context():
        db.session.scalar(sa.select(Study)).status = "closed"
        db.session.commit()
    closed = joined.vote(theirs, "left")
    assert closed.status_code == 409 and closed.json["closed"] is True
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Vote.id))) == 0


def test_the_last_vote_finishes_and_a_failed_check_gives_the_slot_back(app, participant, web):
    from app.web.models import Trial
    from tests.conftest import ParticipantActions

    study_id = web.study(design="all_ordered", catch=2)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    careful, careless = participant, ParticipantActions(app.test_client(), app)
    for person in (careful, careless):
        person.join(slug)
    with app.app_context():
        expected = dict(db.session.execute(sa.select(Trial.id, Trial.expected)).all())
    for person, attentive in ((careful, True), (careless, False)):
        while (trial := person.current_trial()) is not None:
            wanted = expected[trial]
            choice = wanted if attentive or wanted is None else "left"
            assert person.vote(trial, choice or "left").status_code == 201
    with app.app_context():
        people = {p.token: p for p in db.session.scalars(sa.select(Participant))}
        assert people[careful.token].finished_at is not None
        assert people[careful.token].dropped_at is None
        # Left out of the report (catch_failed), so the list slot went back.
        assert people[careless.token].finished_at is not None
        assert people[careless.token].dropped_at is not None
        assert sum(db.session.scalars(sa.select(StudyList.n_assigned))) == 1


def _page_shows(client, token):
    """What the trial page shows of its pair: None once the schedule is done (a redirect)."""
    page = client.get(f"/p/{token}/trial")
    if page.status_code == 302:
        return None
    html = page.get_data(as_text=True)

    def attribute(name):
        found = re.search(rf'data-{name}="([^"]*)"', html)
        return None if found is None else found.group(1)

    instructed = re.search(r'class="instructed">For this pair, please choose <strong>(\w+)', html)
    progress = re.search(r"Pair (\d+) of (\d+)", html)
    return {
        "trial_id": int(attribute("trial-id")),
        "plays": int(attribute("plays")),
        "video_url": attribute("video-url"),
        "preload_url": attribute("preload-url"),
        # the WebM renditions (none here: the test's renders write MP4s only)
        "webm_url": attribute("webm-url"),
        "preload_webm_url": attribute("preload-webm-url"),
        "instructed": None if instructed is None else instructed.group(1),
    }, (int(progress.group(1)) - 1, int(progress.group(2)))


@pytest.mark.parametrize("catch_kind", ["instructed", "onscreen"])
def test_the_answer_carries_the_next_pair_as_its_trial_page_shows_it(
    app, participant, web, catch_kind
):
    """Every vote's ``next_trial`` is what the trial page loaded after it shows: the pair,
    its plays so far, its clip and the one preloaded, the catch instruction; the progress is
    the answer's ``answered``/``total``. The last vote's is null."""
    study_id = web.study(design="all_ordered", catch=2, catch_kind=catch_kind)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    token = participant.join(slug)
    client = participant.client
    shown, progress = _page_shows(client, token)
    carried = []
    while True:
        if shown["preload_url"]:
            # A play of the pair after this one, asked for early: the answer carries its count.
            following = int(shown["preload_url"].rsplit("/", 1)[1])
            early = client.post("/api/v1/plays", json={"token": token, "trial_id": following})
            assert early.status_code == 200
        key = f"carried-{shown['trial_id']:08d}"
        answer = participant.vote(shown["trial_id"], shown["instructed"] or "left", key=key)
        assert answer.status_code == 201, answer.json
        # A resent vote (its answer lost) is answered with the same next pair.
        again = participant.vote(shown["trial_id"], shown["instructed"] or "left", key=key)
        assert again.status_code == 200 and again.json["next_trial"] == answer.json["next_trial"]
        after = _page_shows(client, token)
        if after is None:
            assert answer.json["next_trial"] is None
            assert answer.json["answered"] == answer.json["total"]
            break
        shown, progress = after
        assert answer.json["next_trial"] == shown
        assert (answer.json["answered"], answer.json["total"]) == progress
        carried.append(shown)
        # A play of the carried pair counts on the server, as the page then shows it.
        played = client.post("/api/v1/plays", json={"token": token, "trial_id": shown["trial_id"]})
        assert played.status_code == 200
        shown["plays"] += 1
        assert _page_shows(client, token) == (shown, progress)
    assert len(carried) == progress[1] - 1
    assert all(s["plays"] == 2 for s in carried)  # the early play and the one after the answer
    assert [s["preload_url"] is None for s in carried][-1] is True  # the last preloads none
    # The instruction comes along as text, unless the clip shows it on screen.
    assert any(s["instructed"] for s in carried) == (catch_kind == "instructed")


def _primed(app, joined) -> int:
    """The participant's first vote, which gives the application its study's rules (PostgreSQL
    only); the trial after it."""
    if not app.config["SQLALCHEMY_DATABASE_URI"].startswith("postgresql"):
        pytest.skip("the vote in one statement is PostgreSQL's")
    first = joined.vote(joined.current_trial(), "left")
    assert first.status_code == 201
    return first.json["next_trial"]["trial_id"]


def _votes(app) -> list[tuple[int, str, int]]:
    with app.app_context():
        return [
            (v.trial_id, v.choice, v.plays)
            for v in db.session.scalars(sa.select(Vote).order_by(Vote.id))
        ]


def test_a_vote_that_waited_for_another_of_the_same_participant_counts_both(app, joined):
    """A vote of the same participant's committed while this one waited for their row is
    seen by this one: both counted, and the next pair is neither."""
    if not app.config["SQLALCHEMY_DATABASE_URI"].startswith("postgresql"):
        pytest.skip("a second connection holding the row is PostgreSQL's (SQLite locks the file)")
    import psycopg

    first = joined.vote(joined.current_trial(), "left")
    assert first.status_code == 201
    trial = first.json["next_trial"]["trial_id"]
    with app.app_context():
        person = db.session.scalar(sa.select(Participant))
        other = db.session.scalar(
            sa.select(Trial.id)
            .where(Trial.participant_id == person.id, Trial.kind != "practice")
            .order_by(Trial.position.desc())
            .limit(1)
        )
        dsn = db.engine.url.set(drivername="postgresql").render_as_string(hide_password=False)
    assert other != trial
    answers = []
    with psycopg.connect(dsn) as blocker, psycopg.connect(dsn, autocommit=True) as watcher:
        # Another request of theirs, holding their row: marked seen, its vote inserted.
        blocker.execute("SELECT id FROM participant WHERE id = %s FOR UPDATE", (person.id,))
        blocker.execute("UPDATE participant SET last_seen_at = now() WHERE id = %s", (person.id,))
        blocker.execute(
            "INSERT INTO vote (participant_id, trial_id, idempotency_key, choice, plays, "
            "voted_at) VALUES (%s, %s, 'the-other-request', 'left', 1, now())",
            (person.id, other),
        )
        voter = threading.Thread(target=lambda: answers.append(joined.vote(trial, "right")))
        voter.start()
        for _ in range(200):  # until the vote waits for the row
            waiting = watcher.execute(
                "SELECT count(*) FROM pg_stat_activity WHERE wait_event_type = 'Lock' "
                "AND datname = current_database()"
            ).fetchone()[0]
            if waiting:
                break
            time.sleep(0.02)
        assert waiting, "the vote never waited for the participant's row"
        blocker.commit()
        voter.join(10)
    (answer,) = answers
    assert answer.status_code == 201 and answer.json["answered"] == 3
    assert answer.json["next_trial"]["trial_id"] not in (trial, other)
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Vote.id))) == 3
