"""The vote's usual case (``app.vote_path``): the same answers as the ORM path, in two
statements on PostgreSQL, and the ORM path for what is not the usual case."""

import re

import pytest
import sqlalchemy as sa

from app import voting
from app.extensions import db
from app.models import Participant, Study, Vote
from tests.api.test_views import MEDIA  # a media log of every field


@pytest.fixture
def joined(app, participant, web):
    study_id = web.study(design="all_ordered")  # several trials
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    participant.join(slug)
    return participant


@pytest.fixture
def orm_calls(monkeypatch):
    """How often a vote took the ORM path (``app.voting.record_vote``)."""
    calls = []
    original = voting.record_vote

    def counted(*args, **kwargs):
        calls.append(args)
        return original(*args, **kwargs)

    monkeypatch.setattr("app.api.views.record_vote", counted)
    return calls


def _statements(app):
    seen: list[str] = []
    with app.app_context():
        engine = db.engine

    def before(_conn, _cursor, statement, *_args):
        seen.append(statement.split()[0].upper())

    sa.event.listen(engine, "before_cursor_execute", before)
    return seen, lambda: sa.event.remove(engine, "before_cursor_execute", before)


def _on_driver(monkeypatch) -> list[str]:
    """The first word of every statement run on the driver (``app.driver.execute``)."""
    from app import driver

    seen: list[str] = []
    original = driver.execute

    def counted(cursor, statement, values):
        seen.append(statement.sql.split()[0].upper())
        return original(cursor, statement, values)

    monkeypatch.setattr(driver, "execute", counted)
    return seen


def test_a_vote_a_retry_and_a_double_click_take_the_usual_path(app, joined, orm_calls):
    trial = joined.current_trial()
    first = joined.vote(trial, "right", key="key-one-0001")
    assert first.status_code == 201 and first.json["status"] == "recorded"
    assert first.json["vote"] == {
        "trial_id": trial,
        "choice": "right",
        "plays": 1,
        "response_ms": 1234,
        "strength": None,
    }
    assert first.json["answered"] == 1 and first.json["next"].endswith(f"/p/{joined.token}")
    retry = joined.vote(trial, "right", key="key-one-0001")
    assert retry.status_code == 200 and retry.json["status"] == "duplicate"
    assert retry.json["vote"] == first.json["vote"]
    double = joined.vote(trial, "left", key="key-two-0002")  # a second click, a new key
    assert double.status_code == 200 and double.json["vote"]["choice"] == "right"
    assert orm_calls == []
    with app.app_context():
        votes = db.session.scalars(sa.select(Vote)).all()
        assert [(v.trial_id, v.choice, v.idempotency_key) for v in votes] == [
            (trial, "right", "key-one-0001")
        ]
        person = db.session.scalar(sa.select(Participant))
        assert person.last_seen_at >= person.consented_at


def test_the_usual_vote_is_one_statement_on_postgresql_once_the_rules_are_known(
    app, joined, monkeypatch
):
    if not app.config["SQLALCHEMY_DATABASE_URI"].startswith("postgresql"):
        pytest.skip("SQLite runs the second statement as four, in process")
    from app import driver

    on_driver = _on_driver(monkeypatch)
    transactions = []
    original = driver.transaction

    def counted():
        transactions.append(1)
        return original()

    monkeypatch.setattr(driver, "transaction", counted)
    first_trial = joined.current_trial()
    seen, stop = _statements(app)
    try:
        first = joined.vote(first_trial, "left", key="retried-key-01")
        again = joined.vote(first_trial, "left", key="retried-key-01")
        double = joined.vote(first_trial, "right", key="clicked-twice-1")
        second = joined.vote(first.json["next_trial"]["trial_id"], "right", key="second-key-01")
    finally:
        stop()
    assert first.status_code == 201 and first.json["answered"] == 1  # not the last: no finish
    assert again.status_code == 200 and again.json["status"] == "duplicate"
    assert again.json["vote"] == first.json["vote"] and again.json["answered"] == 1
    assert double.status_code == 200 and double.json["vote"] == first.json["vote"]
    assert second.status_code == 201 and second.json["answered"] == 2
    assert second.json["vote"]["trial_id"] != first_trial
    assert second.json["next_trial"]["trial_id"] not in (
        first_trial,
        second.json["vote"]["trial_id"],
    )
    # All on the driver (BEGIN and COMMIT are its own, not statements); SQLAlchemy ran none.
    # The application's first vote reads, then stores with the next pair, in a transaction;
    # once its study's rules are known, a vote is one statement, in autocommit.
    assert on_driver == ["SELECT", "WITH", "WITH", "WITH", "WITH"], on_driver
    assert len(transactions) == 1
    assert seen == [], seen
    with app.app_context():
        stored = db.session.scalars(sa.select(Vote).order_by(Vote.id)).all()
        assert [(v.trial_id, v.choice, v.plays) for v in stored] == [
            (first_trial, "left", 1),
            (second.json["vote"]["trial_id"], "right", 1),
        ]
        person = db.session.scalar(sa.select(Participant))
        assert person.last_seen_at >= stored[-1].voted_at


def test_a_lost_database_connection_on_the_driver_path_is_a_503(app, joined, monkeypatch):
    if not app.config["SQLALCHEMY_DATABASE_URI"].startswith("postgresql"):
        pytest.skip("the driver's path is PostgreSQL's")
    import psycopg

    from app import driver

    def lost(cursor, statement, values):
        raise psycopg.OperationalError("server closed the connection unexpectedly")

    monkeypatch.setattr(driver, "execute", lost)
    trial = joined.current_trial()
    answer = joined.vote(trial, "left")
    assert answer.status_code == 503
    monkeypatch.undo()
    # The broken connection was dropped, not pooled: the next vote is stored.
    assert joined.vote(trial, "left").status_code == 201
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Vote.id))) == 1


def test_what_is_not_the_usual_case_takes_the_orm_path(app, joined, orm_calls):
    trial = joined.current_trial()
    assert joined.vote(trial, "left", key="shared-key-01").status_code == 201
    other = joined.current_trial()
    # The key of another trial's vote: the insert meets it, the ORM path says which.
    reused = joined.vote(other, "left", key="shared-key-01")
    assert reused.status_code == 409 and "another trial" in reused.json["error"]
    assert len(orm_calls) == 1
    # An unknown participant is the ORM path's 403.
    assert (
        joined.client.post(
            "/api/v1/votes", json={"token": "nobody-at-all", "trial_id": trial}
        ).status_code
        == 403
    )
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Vote.id))) == 1


def test_another_participants_trial_and_a_closed_study_are_refused(app, client, joined, web):
    from tests.conftest import ParticipantActions

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
    from app.models import StudyList, Trial
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


def test_the_drivers_vote_is_stored_as_the_sessions_is(app, joined, monkeypatch):
    if not app.config["SQLALCHEMY_DATABASE_URI"].startswith("postgresql"):
        pytest.skip("the driver's path is PostgreSQL's")
    from app import driver

    by_driver = joined.current_trial()
    assert joined.vote(by_driver, "left", key="by-the-driver").status_code == 201
    monkeypatch.setattr(driver, "available", lambda: False)  # the session's path
    by_session = joined.current_trial()
    assert joined.vote(by_session, "left", key="by-the-session").status_code == 201
    _stored_alike(app, by_driver, by_session)


def _stored_alike(app, one: int, other: int) -> None:
    """The votes on trials ``one`` and ``other`` are stored alike, column by column, in the
    stored form itself (a JSON null and an SQL NULL read back differently), but for their
    keys and times, which differ by design."""
    columns = [c.name for c in Vote.__table__.columns if c.name not in ("id", "trial_id")]
    with app.app_context():
        rows = [
            db.session.execute(
                sa.text(
                    "SELECT "
                    + ", ".join(f"{c}::text IS NULL, {c}::text" for c in columns)
                    + " FROM vote WHERE trial_id = :trial"
                ),
                {"trial": trial},
            ).one()
            for trial in (one, other)
        ]
    for i, name in enumerate(columns):
        if name not in ("idempotency_key", "voted_at"):
            assert rows[0][2 * i : 2 * i + 2] == rows[1][2 * i : 2 * i + 2], name


@pytest.mark.parametrize("attentive", [True, False], ids=["attentive", "left-out"])
def test_the_vote_that_finishes_a_participant_stays_on_the_driver(
    app, participant, web, monkeypatch, orm_calls, attentive
):
    if not app.config["SQLALCHEMY_DATABASE_URI"].startswith("postgresql"):
        pytest.skip("the driver's path is PostgreSQL's")
    from app.models import StudyList, Trial

    study_id = web.study(design="all_ordered", catch=2)  # the default catch_failed rule
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    participant.join(slug)
    with app.app_context():
        expected = dict(db.session.execute(sa.select(Trial.id, Trial.expected)).all())
    on_driver = _on_driver(monkeypatch)
    answer = None
    while (trial := participant.current_trial()) is not None:
        choice = expected[trial] if attentive or expected[trial] is None else "left"
        on_driver.clear()
        seen, stop = _statements(app)
        try:
            answer = participant.vote(trial, choice or "left")
        finally:
            stop()
        assert answer.status_code == 201
        # The page fetched by current_trial() is the session's; the vote is the driver's.
        assert seen == [], seen
    assert answer is not None and answer.json["answered"] == answer.json["total"]
    # The last vote: the one statement (the study's rules are known by then) leaves
    # finishing to the transaction: read, store, ask for a failed check, mark finished (and
    # give the list slot back, for the participant the report leaves out).
    finish = "UPDATE" if attentive else "WITH"
    assert on_driver == ["WITH", "SELECT", "WITH", "SELECT", finish], on_driver
    assert orm_calls == []
    with app.app_context():
        person = db.session.scalar(sa.select(Participant))
        assert person.finished_at is not None
        assert (person.dropped_at is None) == attentive
        assert sum(db.session.scalars(sa.select(StudyList.n_assigned))) == int(attentive)


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
        "instructed": None if instructed is None else instructed.group(1),
    }, (int(progress.group(1)) - 1, int(progress.group(2)))


@pytest.mark.parametrize("catch_kind", ["instructed", "onscreen"])
def test_the_answer_carries_the_next_pair_as_its_trial_page_shows_it(
    app, participant, web, orm_calls, catch_kind
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
    # Only the resent last vote of a participant left out for a missed check (answered
    # "left" whatever the clip said) takes the ORM path: they are dropped by then.
    assert len(orm_calls) <= (catch_kind == "onscreen")


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


def test_rules_changed_since_the_last_vote_are_the_studys_own(app, joined, monkeypatch):
    trial = _primed(app, joined)
    with app.app_context():
        db.session.scalar(sa.select(Study)).allow_undecided = False
        db.session.commit()
    on_driver = _on_driver(monkeypatch)
    refused = joined.vote(trial, "undecided")
    # Accepted by the rules the application knew, so tried in one statement, which stored
    # nothing: the study's rules are not those; the transaction's path refuses it.
    assert refused.status_code == 400 and refused.json["error"].startswith("choice")
    assert on_driver == ["WITH", "SELECT"]
    assert len(_votes(app)) == 1
    on_driver.clear()
    stored = joined.vote(trial, "left")
    assert stored.status_code == 201 and stored.json["answered"] == 2
    assert on_driver == ["WITH", "SELECT", "WITH"]  # stored by the transaction, which learns
    on_driver.clear()
    assert joined.vote(stored.json["next_trial"]["trial_id"], "right").status_code == 201
    assert on_driver == ["WITH"]  # the new rules are known
    assert len(_votes(app)) == 3


def test_a_closed_study_refuses_the_vote_the_last_rules_accept(app, joined, monkeypatch):
    trial = _primed(app, joined)
    with app.app_context():
        db.session.scalar(sa.select(Study)).status = "closed"
        db.session.commit()
    on_driver = _on_driver(monkeypatch)
    refused = joined.vote(trial, "left")
    assert refused.status_code == 409 and refused.json["closed"] is True
    assert on_driver == ["WITH", "SELECT"]
    assert len(_votes(app)) == 1


def test_the_servers_play_count_wins_over_the_pages_in_one_statement_too(app, joined, monkeypatch):
    trial = _primed(app, joined)
    for _ in range(2):
        played = joined.client.post(
            "/api/v1/plays", json={"token": joined.token, "trial_id": trial}
        )
        assert played.status_code == 200
    on_driver = _on_driver(monkeypatch)
    counted = joined.vote(trial, "left", plays=1)
    assert counted.status_code == 201 and counted.json["vote"]["plays"] == 2
    assert on_driver == ["WITH", "SELECT", "WITH"]  # the page's count was not the server's
    following = counted.json["next_trial"]["trial_id"]
    assert (
        joined.client.post(
            "/api/v1/plays", json={"token": joined.token, "trial_id": following}
        ).status_code
        == 200
    )
    on_driver.clear()
    same = joined.vote(following, "right", plays=1)
    assert same.status_code == 201 and same.json["vote"]["plays"] == 1
    assert on_driver == ["WITH"]
    assert [plays for *_, plays in _votes(app)] == [1, 2, 1]


def test_a_vote_committed_while_the_statement_waited_is_counted(app, joined, monkeypatch):
    """A vote of the same participant's, committed while the one statement waited for their
    row, is missing from that statement's snapshot: it stores nothing, and the transaction's
    path counts both."""
    import threading
    import time

    import psycopg

    from app.models import Trial

    trial = _primed(app, joined)
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
    on_driver = _on_driver(monkeypatch)
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
        for _ in range(200):  # until the vote's statement waits for the row
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
    assert on_driver == ["WITH", "SELECT", "WITH"]
    assert sorted(t for t, *_ in _votes(app))[1:] == sorted([trial, other])


def test_a_stop_rule_for_attention_checks_keeps_the_transaction(app, participant, web, monkeypatch):
    study_id = web.study(design="all_ordered", catch=2, extra="[attention]\nmax_failed = 1\n")
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    participant.join(slug)
    trial = _primed(app, participant)
    on_driver = _on_driver(monkeypatch)
    assert participant.vote(trial, "left").status_code == 201
    # Never the one statement: a missed check may end the session, which the transaction's
    # path (or the session's, for a missed check) decides.
    assert on_driver[:1] == ["SELECT"], on_driver


FIVE_LEVELS = '[answer]\nscale = 5\nreasons = ["lips", "head"]\n'


def test_the_vote_in_one_statement_is_stored_as_the_transactions_is(
    app, participant, web, monkeypatch
):
    study_id = web.study(design="all_ordered", extra=FIVE_LEVELS)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    participant.join(slug)
    if not app.config["SQLALCHEMY_DATABASE_URI"].startswith("postgresql"):
        pytest.skip("the vote in one statement is PostgreSQL's")
    on_driver = _on_driver(monkeypatch)
    answer = {"strength": 2, "reasons": ["head", "lips"], "media": MEDIA}
    by_transaction = participant.current_trial()
    first = participant.vote(by_transaction, "right", key="by-the-transaction", **answer)
    at_once = first.json["next_trial"]["trial_id"]
    second = participant.vote(at_once, "right", key="in-one-statement", **answer)
    assert first.status_code == second.status_code == 201
    assert second.json["vote"] == {**first.json["vote"], "trial_id": at_once}
    assert on_driver == ["SELECT", "WITH", "WITH"]
    _stored_alike(app, at_once, by_transaction)


def test_a_dropped_or_screened_out_participant_is_not_voted_for_in_one_statement(
    app, joined, monkeypatch, orm_calls
):
    trial = _primed(app, joined)
    on_driver = _on_driver(monkeypatch)
    for column in ("dropped_at", "screened_out_at"):
        with app.app_context():
            person = db.session.scalar(sa.select(Participant))
            setattr(person, column, person.consented_at)
            db.session.commit()
        on_driver.clear()
        answer = joined.vote(trial, "left")
        assert on_driver == ["WITH"], column  # read, nothing stored: the ORM's path decides
        assert len(orm_calls) == 1
        orm_calls.clear()
        if column == "screened_out_at":
            assert answer.status_code == 409 and answer.json["closed"] is True
        with app.app_context():
            person = db.session.scalar(sa.select(Participant))
            setattr(person, column, None)
            db.session.commit()
    with app.app_context():
        # The first vote, and the dropped participant's, stored on rejoining (the ORM's way).
        assert db.session.scalar(sa.select(sa.func.count(Vote.id))) == 2
