"""Enrolment (``app.web.study.enrolment``): a reproducible schedule from the stored seed,
lists balanced from the assignment table, and drop-outs who come back: a dropped participant
who returns takes their list slot back (``rejoin = "resume"``) or is refused with a message
(``rejoin = "refuse"``); the assignment table always agrees with who holds a slot."""

import datetime as dt
import re

import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Stimulus, Study, StudyList
from app.web.study.enrolment import release_dropped, schedule
from tests.support.studies import study_slug


def _go_idle(app, token: str) -> None:
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        person.last_seen_at = person.last_seen_at - dt.timedelta(hours=3)
        db.session.commit()


def _slots(app) -> int:
    with app.app_context():
        return sum(row.n_assigned for row in db.session.scalars(sa.select(StudyList)))


def _row(app, token: str) -> Participant:
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        db.session.expunge(person)
        return person


def _answer_all(participant) -> int:
    answered = 0
    while (trial := participant.current_trial()) is not None:
        assert participant.vote(trial).status_code == 201
        answered += 1
    return answered


def test_a_dropped_participant_who_returns_takes_the_slot_back(app, client, participant, web):
    study_id = web.study(design="all_ordered")
    token = participant.join(study_slug(app, study_id))
    trial = participant.current_trial()
    assert participant.vote(trial).status_code == 201
    _go_idle(app, token)
    web.login(client)
    monitor = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    assert re.search(r'id="stat-dropped">1<', monitor)
    assert _slots(app) == 0
    assert _answer_all(participant) > 0  # back, and finishes
    person = _row(app, token)
    assert person.finished_at is not None and person.dropped_at is None
    assert _slots(app) == 1  # the finished participant holds their list again
    monitor = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    assert re.search(r'id="stat-finished">1<', monitor)
    assert re.search(r'id="stat-dropped">0<', monitor)


def test_a_returning_vote_alone_takes_the_slot_back(app, participant, web):
    study_id = web.study(design="all_ordered")
    token = participant.join(study_slug(app, study_id))
    trial = participant.current_trial()  # the page was open before the pause
    _go_idle(app, token)
    with app.app_context():
        assert release_dropped(db.session.get(Study, study_id), after=dt.timedelta(hours=1)) == 1
        db.session.commit()
    assert participant.vote(trial).status_code == 201
    assert _row(app, token).dropped_at is None
    assert _slots(app) == 1


def test_refused_when_the_study_file_says_so(app, client, participant, web):
    study_id = web.study(design="all_ordered", extra='rejoin = "refuse"')
    token = participant.join(study_slug(app, study_id))
    trial = participant.current_trial()
    _go_idle(app, token)
    with app.app_context():
        assert release_dropped(db.session.get(Study, study_id), after=dt.timedelta(hours=1)) == 1
        db.session.commit()
    page = client.get(f"/p/{token}/trial")
    assert page.status_code == 410
    assert "Your session ended after a long pause" in page.get_data(as_text=True)
    response = participant.vote(trial)
    assert response.status_code == 409
    assert response.get_json()["closed"] is True  # final: the browser does not resend it
    assert "your place was given to another participant" in response.get_json()["error"]
    assert _row(app, token).dropped_at is not None
    assert _slots(app) == 0


def test_new_arrivals_are_balanced_over_those_still_taking_part(app, client, web):
    """An idle participant's list goes to the next arrival without anyone opening the
    monitor."""
    from tests.conftest import ParticipantActions

    study_id = web.study(design="all_ordered")
    slug = study_slug(app, study_id)
    first = ParticipantActions(app.test_client(), app)
    first.join(slug)
    _go_idle(app, first.token)
    second = ParticipantActions(app.test_client(), app)
    second.join(slug)
    first_row, second_row = _row(app, first.token), _row(app, second.token)
    assert first_row.dropped_at is not None
    assert second_row.list_id == first_row.list_id  # the least-filled list again
    assert _slots(app) == 1


def test_release_and_return_never_count_a_slot_twice(app, participant, web):
    from app.web.study.enrolment import touch

    study_id = web.study(design="all_ordered")
    token = participant.join(study_slug(app, study_id))
    _go_idle(app, token)
    with app.app_context():
        study = db.session.get(Study, study_id)
        assert release_dropped(study, after=dt.timedelta(hours=1)) == 1
        assert release_dropped(study, after=dt.timedelta(hours=1)) == 0
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        assert touch(person) and touch(person)
        db.session.commit()
    assert _slots(app) == 1


def test_schedule_is_reproducible_from_the_stored_seed(app, participant, web):
    slug = study_slug(app, web.study(catch=1))
    token = participant.join(slug)
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        stored = [
            (t.position, t.kind, t.stimulus.left.name, t.stimulus.right.name) for t in person.trials
        ]
        rebuilt = [
            (t.position, t.kind, t.left, t.right)
            for t in schedule(person.study, seed=person.seed, list_index=person.study_list.index)
        ]
        assert stored == rebuilt
        assert [t.kind for t in person.trials].count("catch") == 1
        assert person.trials[0].kind == "practice"


def test_lists_are_balanced_from_the_assignment_table(app, client, web):
    slug = study_slug(app, web.study())
    tokens = []
    for _ in range(4):
        fresh = app.test_client()  # a new browser: no cookie
        actions = type(web)  # noqa: F841 - keeps the namespace import honest
        page = fresh.get(f"/s/{slug}")
        token = re.search(r'name="csrf_token"[^>]*value="([^"]+)"', page.get_data(as_text=True))
        response = fresh.post(f"/s/{slug}", data={"csrf_token": token.group(1), "agree": "1"})
        tokens.append(response.headers["Location"].split("/p/")[1].split("/")[0])
    with app.app_context():
        lists = db.session.scalars(sa.select(StudyList).order_by(StudyList.index)).all()
        assert [row.n_assigned for row in lists] == [2, 2]  # unordered design: two side lists
        people = db.session.scalars(sa.select(Participant)).all()
        assert sorted(p.number for p in people) == [0, 1, 2, 3]
        # Each pair is shown in both orders across the two lists.
        orders = {
            (p.study_list.index, t.stimulus.left.name)
            for p in people
            for t in p.trials
            if t.kind == "trial"
        }
        assert {o for _, o in orders} == {"none", "random"}


def test_the_design_read_once_matches_the_studys_rows(app, participant, web):
    from app.web.study import enrolment
    from app.web.study.studies import design_pairs

    study_id = web.study(catch=1)  # counterbalanced: more than one list
    with app.app_context():
        study = db.session.get(Study, study_id)
        fixed = enrolment.study_design(study)
        assert list(fixed.clip_names) == [c.name for c in study.clips]
        assert fixed.clips == {c.name: c.id for c in study.clips}
        assert fixed.conditions == {c.name: c.id for c in study.conditions}
        assert list(fixed.pairs) == design_pairs(study)
        assert fixed.n_lists == len(study.lists) > 1
        for pair in study.pairs:
            assert fixed.pair_ids[(pair.first_id, pair.second_id)] == pair.id
            assert fixed.pair_ids[(pair.second_id, pair.first_id)] == pair.id
        stored = db.session.scalars(sa.select(Stimulus).where(Stimulus.study_id == study_id))
        assert fixed.stimuli == {
            (s.clip_id, s.left_id, s.right_id, s.instruction, s.foreign_side): s.id for s in stored
        }


def test_a_consent_reads_the_design_only_the_first_time(app, client, web):
    from tests.conftest import ParticipantActions

    slug = study_slug(app, web.study(design="all_ordered", catch=1))
    design_tables = ("clip", "condition", "pair", "study_list", "stimulus")
    statements: list[str] = []

    def seen(conn, cursor, statement, parameters, context, executemany):
        statements.append(statement)

    with app.app_context():
        sa.event.listen(db.engine, "before_cursor_execute", seen)
    try:
        counts = []
        for _ in range(2):
            statements.clear()
            ParticipantActions(app.test_client(), app).join(slug)
            reads = [
                s
                for s in statements
                if s.lstrip().upper().startswith("SELECT")
                and re.search(r"\bFROM (" + "|".join(design_tables) + r")\b", s)
            ]
            counts.append(len(reads))
    finally:
        with app.app_context():
            sa.event.remove(db.engine, "before_cursor_execute", seen)
    # The first consent reads clips, conditions, pairs, the list count and the stimuli; the
    # second only the list counts it balances on.
    assert counts[0] >= counts[1] + 5
    assert counts[1] == 1


def test_a_study_created_again_under_the_same_id_gets_its_own_design(app, web):
    from app.web.study.studies import delete_study
    from tests.conftest import ParticipantActions

    first = web.study(design="all_ordered")
    ParticipantActions(app.test_client(), app).join(study_slug(app, first))
    with app.app_context():
        delete_study(db.session.get(Study, first))
        db.session.commit()
    second = web.study(catch=1)
    token = ParticipantActions(app.test_client(), app).join(study_slug(app, second))
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        own = set(db.session.scalars(sa.select(Stimulus.id).where(Stimulus.study_id == second)))
        assert person.trials and {t.stimulus_id for t in person.trials} <= own
        rebuilt = schedule(person.study, seed=person.seed, list_index=person.study_list.index)
        assert [(t.position, t.kind) for t in person.trials] == [
            (t.position, t.kind) for t in rebuilt
        ]


def test_a_design_is_read_once_and_the_designs_kept_are_bounded(app, web):
    from app.web.study import enrolment

    ids = [web.study(), web.study()]
    enrolment._design.cache_clear()
    with app.app_context():
        for study_id in [*ids, *ids]:
            study = db.session.get(Study, study_id)
            assert enrolment.study_design(study) is enrolment.study_design(study)
    found = enrolment._design.cache_info()
    assert (found.misses, found.hits, found.maxsize) == (2, 6, 64)


def test_a_trial_page_marks_the_participant_seen_then_counts(app, participant, web):
    from app.web.study.enrolment import touch_with_progress
    from app.web.study.progress import progress

    token = participant.join(study_slug(app, web.study(design="all_ordered")))
    participant.vote(participant.current_trial())
    _go_idle(app, token)  # idle, not yet released
    statements: list[str] = []

    def seen(conn, cursor, statement, parameters, context, executemany):
        statements.append(statement.split()[0].upper())

    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        before = person.last_seen_at
        sa.event.listen(db.engine, "before_cursor_execute", seen)
        try:
            counts = touch_with_progress(person)
        finally:
            sa.event.remove(db.engine, "before_cursor_execute", seen)
        assert counts == progress(person) and counts[0] == 1 and counts[1] > 1
        db.session.commit()
        assert person.last_seen_at > before
    # The one sign of life (app.web.study.enrolment.touch), then both counts in one statement.
    assert statements == ["UPDATE", "SELECT"], statements


def test_a_released_participant_s_trial_page_takes_the_slot_back_or_ends(app, participant, web):
    from app.web.study.enrolment import touch_with_progress

    for rejoin, expected_slots in (("resume", 1), ("refuse", 0)):
        who = participant.__class__(app.test_client(), app)
        extra = f'rejoin = "{rejoin}"\n'
        token = who.join(study_slug(app, web.study(extra=extra)))
        _go_idle(app, token)
        with app.app_context():
            person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
            assert release_dropped(person.study, after=dt.timedelta(hours=1)) == 1
            counts = touch_with_progress(person)
            db.session.commit()
            slots = db.session.scalar(
                sa.select(StudyList.n_assigned).where(StudyList.id == person.list_id)
            )
            assert slots == expected_slots, rejoin
            if rejoin == "resume":
                assert counts is not None and counts[0] == 0
                assert person.dropped_at is None
            else:
                assert counts is None and person.dropped_at is not None


def test_a_trial_page_sets_the_start_once(app, participant, web):
    token = participant.join(study_slug(app, web.study(design="all_ordered")))
    participant.current_trial()
    first = _row(app, token).started_at
    assert first is not None
    participant.current_trial()
    assert _row(app, token).started_at == first


def test_a_left_out_participant_s_resent_last_vote_takes_no_slot_back(app, participant, web):
    from app.web.models import Trial

    for rejoin in ("resume", "refuse"):
        who = participant.__class__(app.test_client(), app)
        token = who.join(
            study_slug(
                app, web.study(design="all_ordered", catch=2, extra=f'rejoin = "{rejoin}"\n')
            )
        )
        with app.app_context():
            kinds = dict(db.session.execute(sa.select(Trial.id, Trial.kind)).all())
        last = None
        while (trial := who.current_trial()) is not None:
            # Every catch trial failed: left out of the report, the slot goes back at the end.
            last = trial
            choice = "left" if kinds[trial] == "catch" else "right"
            assert who.vote(trial, choice, key=f"vote-key-{trial}").status_code == 201
        person = _row(app, token)
        assert person.finished_at is not None and person.dropped_at is not None
        slots_before = _slots(app)
        # The last vote sent again, as a browser does when its answer was lost.
        choice = "left" if kinds[last] == "catch" else "right"
        resent = who.vote(last, choice, key=f"vote-key-{last}")
        # The answer is the stored vote; the participant stays released, the slot given back.
        assert resent.status_code == 200 and resent.json["status"] == "duplicate", rejoin
        assert _row(app, token).dropped_at is not None
        assert _slots(app) == slots_before, rejoin


def _idle_for(app, token: str, minutes: float) -> None:
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        person.last_seen_at = person.last_seen_at - dt.timedelta(minutes=minutes)
        db.session.commit()


def test_a_consent_that_never_starts_gives_its_slot_back_early(app, participant, web, client):
    """20 minutes after consent without a first trial: released (UNSTARTED_AFTER_MINUTES, 15),
    while a participant who started and paused as long keeps the slot (DROPPED_AFTER, 30)."""
    slug = study_slug(app, web.study(design="all_ordered"))
    idle = participant.join(slug)  # consented, never opened a trial
    from tests.conftest import ParticipantActions

    started = ParticipantActions(app.test_client(), app)
    started_token = started.join(slug)
    assert started.current_trial() is not None  # the first trial page: started
    _idle_for(app, idle, 20)
    _idle_for(app, started_token, 20)
    assert _slots(app) == 2
    newcomer = ParticipantActions(app.test_client(), app)
    newcomer.join(slug)  # each consent releases the idle first
    assert _row(app, idle).dropped_at is not None
    assert _row(app, started_token).dropped_at is None
    assert _slots(app) == 2  # the newcomer took the slot the idle one gave back


def test_the_release_reads_the_active_participants_index(app, web):
    """The query behind every consent's release uses the partial index, so its cost follows
    those taking part now, not the study's size (EXPLAIN on both databases, the study holding
    2,000 finished participants and the planner's statistics fresh: in an empty table two
    indexes cost the same and the planner's pick depends on what earlier tests left)."""
    from app.web.study import enrolment

    study_id = web.study()
    with app.app_context():
        list_id = db.session.scalar(sa.select(StudyList.id).where(StudyList.study_id == study_id))
        done = dt.datetime(2026, 1, 1)
        db.session.execute(
            sa.insert(Participant),
            [
                {
                    "study_id": study_id,
                    "token": f"finished-{n}",
                    "list_id": list_id,
                    "number": n,
                    "seed": n,
                    "consented_at": done,
                    "last_seen_at": done,
                    "finished_at": done,
                }
                for n in range(1000, 3000)
            ],
        )
        db.session.commit()
        db.session.execute(sa.text("ANALYZE participant"))
        db.session.commit()
    captured = []

    def explain(statement):
        compiled = statement.compile(
            dialect=db.engine.dialect, compile_kwargs={"literal_binds": True}
        )
        captured.append(str(compiled))
        return original(statement)

    with app.app_context():
        original = db.session.execute
        db.session.execute = explain  # type: ignore[method-assign]
        try:
            enrolment.release_dropped(
                db.session.get(Study, study_id),
                after=dt.timedelta(minutes=30),
                unstarted_after=dt.timedelta(minutes=15),
            )
        finally:
            del db.session.execute
        select = next(sql for sql in captured if sql.lstrip().upper().startswith("SELECT"))
        if db.engine.dialect.name == "postgresql":
            db.session.execute(sa.text("SET LOCAL enable_seqscan = off"))
            plan = "\n".join(db.session.execute(sa.text("EXPLAIN " + select)).scalars())
        else:
            plan = "\n".join(
                str(row[-1]) for row in db.session.execute(sa.text("EXPLAIN QUERY PLAN " + select))
            )
        db.session.rollback()
    assert "ix_participant_active" in plan, plan


def test_a_crowd_of_consents_to_four_workers_all_enrol(app, web, tmp_path):
    """20 consents at once to 4 gunicorn workers, no consent limit: on PostgreSQL two arrivals
    each held the list whose count they lost while trying the other's, and 5 to 7 of 20 ended
    in a deadlock (503). Now every one enrols and the lists agree with who holds a slot."""
    import secrets

    from tests.support.served import consent_crowd, facepair_serve, serve_env

    study_id = web.study()
    env = serve_env(
        tmp_path,
        DATABASE_URL=app.config["SQLALCHEMY_DATABASE_URI"],
        SECRET_KEY=secrets.token_hex(32),
        MEDIA_ROOT=app.config["MEDIA_ROOT"],
    )
    (tmp_path / "instance").mkdir()
    (tmp_path / "instance" / "config.py").write_text(
        'CONSENT_LIMIT_PER_ADDRESS = ""\nCONSENT_LIMIT_PER_STUDY = ""\n'
    )
    with facepair_serve(env, workers=4, log=tmp_path / "serve.log") as base:
        codes = consent_crowd(base, study_slug(app, study_id), 20)
    assert codes == [302] * 20, codes
    assert _slots(app) == 20
