"""The outbox: two senders at once send a call once; approval waits until Prolific has the
submission awaiting review; a 429 storm leaves calls waiting, not lost; a payment that may have
gone through is never sent again but by a person's decision."""

from __future__ import annotations

import threading

import pytest
import sqlalchemy as sa

from app.errors import InputError
from app.web.extensions import db
from app.web.models import Study
from app.web.prolific.bonus import batches, pay
from app.web.prolific.client import client_from_environment
from app.web.prolific.models import ProlificCall, ProlificStudy, ProlificSubmission
from app.web.prolific.outbox import Intent, drain, record, resolve
from app.web.prolific.review import Decision, decide
from tests.web.prolific.conftest import cli


@pytest.fixture
def published(app, prolific_env, recruiting_study) -> str:
    assert cli("publish", str(recruiting_study), "--yes").exit_code == 0
    with app.app_context():
        made = db.session.scalars(sa.select(ProlificStudy.prolific_id)).one()
        assert made is not None
        return made


def _submitted(
    app, fake, study_id: int, prolific_id: str, *, submit: bool = True
) -> tuple[str, str]:
    sid, pid = fake.start(prolific_id)
    if submit:
        fake.submit(sid, "DONE-123")
    with app.app_context():
        db.session.add(
            ProlificSubmission(
                study_id=study_id, submission_id=sid, prolific_pid=pid, status="ACTIVE"
            )
        )
        db.session.commit()
    return sid, pid


def _row(app, call_id: int) -> ProlificCall:
    with app.app_context():
        row = db.session.get_one(ProlificCall, call_id)
        db.session.expunge(row)
        return row


def test_two_senders_at_once_send_each_call_once(
    app, prolific_env, recruiting_study, published, monkeypatch
):
    fake = prolific_env
    monkeypatch.setenv("PROLIFIC_CLAIM_LEASE_SECONDS", "600")  # no sender is taken for dead
    subs = [_submitted(app, fake, recruiting_study, published) for _ in range(3)]
    with app.app_context():
        study = db.session.get(Study, recruiting_study)
        decide(study, [Decision(sid, "approve") for sid, _ in subs], who="t")
        ((places, _),) = record(
            study.id,
            [Intent("top_up", f"{study.id}:top_up:9", {"total_available_places": 9}, published)],
            created_by="t",
        )
        places_id = places.id
    fake.delay = 0.05
    start = threading.Barrier(2)
    errors: list[BaseException] = []

    def sender() -> None:
        try:
            with app.app_context():
                start.wait()
                drain(recruiting_study, client_from_environment(app.config))
                db.session.remove()
        except BaseException as exc:  # pragma: no cover - shown below
            errors.append(exc)

    threads = [threading.Thread(target=sender) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(60)
    assert not errors, errors
    assert fake.effects[("top_up", published)] == 1
    assert all(fake.effects[("approve", sid)] == 1 for sid, _ in subs)
    assert _row(app, places_id).state == "done"


def test_approval_waits_until_prolific_has_the_submission(
    app, prolific_env, recruiting_study, published
):
    fake = prolific_env
    sid, _ = _submitted(app, fake, recruiting_study, published, submit=False)
    with app.app_context():
        ((call, _),) = decide(
            db.session.get(Study, recruiting_study), [Decision(sid, "approve")], who="t"
        )
        call_id = call.id
        client = client_from_environment(app.config)
        drain(recruiting_study, client)
    waiting = _row(app, call_id)
    assert waiting.state == "pending" and "waits until it is awaiting review" in waiting.note
    assert not any(p.endswith("bulk-approve/") for _, p, _ in fake.requests)
    fake.submit(sid, "DONE-123")
    with app.app_context():
        drain(recruiting_study, client)
    assert _row(app, call_id).state == "done" and fake.effects[("approve", sid)] == 1


def test_a_429_storm_leaves_calls_waiting_not_lost(
    app, prolific_env, recruiting_study, published, monkeypatch
):
    fake = prolific_env
    monkeypatch.setenv("PROLIFIC_ATTEMPTS", "3")
    with app.app_context():
        ((call, _),) = record(
            recruiting_study,
            [
                Intent(
                    "top_up",
                    f"{recruiting_study}:top_up:7",
                    {"total_available_places": 7},
                    published,
                )
            ],
            created_by="t",
        )
        call_id = call.id
        fake.storm = 10_000
        report = drain(recruiting_study, client_from_environment(app.config))
    assert report.left == 1
    stormed = _row(app, call_id)
    assert stormed.state == "pending" and "429 Too Many Requests after 3 attempts" in stormed.note
    fake.storm = 0
    with app.app_context():
        drain(recruiting_study, client_from_environment(app.config))
    assert _row(app, call_id).state == "done" and fake.effects[("top_up", published)] == 1


def _batch(app, fake, study_id: int, prolific_id: str) -> tuple[int, int, str]:
    """A bonus batch set up at Prolific and its payment written: (setup id, pay id, PID)."""
    _, pid = _submitted(app, fake, study_id, prolific_id)
    from decimal import Decimal

    with app.app_context():
        study = db.session.get_one(Study, study_id)
        (found,) = batches(study, {pid: Decimal("2.50")}, who="t")
        drain(study_id, client_from_environment(app.config))
        paying = pay(study, found, who="t")
        return found.setup.id, paying.id, pid


def test_a_payment_whose_answer_is_lost_is_read_back_not_resent(
    app, prolific_env, recruiting_study, published
):
    fake = prolific_env
    fake.crash_after.append("/pay/$")  # Prolific pays, the answer never arrives
    _, pay_id, pid = _batch(app, fake, recruiting_study, published)
    with app.app_context():
        drain(recruiting_study, client_from_environment(app.config))
    paid = _row(app, pay_id)
    assert paid.state == "done" and paid.note == "Prolific shows the bonuses paid"
    assert fake.count("pay") == 1


def test_a_payment_in_doubt_waits_for_a_person(app, prolific_env, recruiting_study, published):
    fake = prolific_env
    fake.fail_next.append(("/pay/$", 500))  # Prolific fails before paying: nobody can tell
    setup_id, pay_id, pid = _batch(app, fake, recruiting_study, published)
    client = client_from_environment(app.config)
    with app.app_context():
        drain(recruiting_study, client)
        drain(recruiting_study, client)
    doubt = _row(app, pay_id)
    assert doubt.state == "doubt" and f"resolve {doubt.id} --sent" in doubt.note
    assert fake.count("pay") == 0
    with app.app_context():
        with pytest.raises(InputError, match="not in doubt"):
            resolve(db.session.get(ProlificCall, setup_id), "sent", who="t")
        resolve(db.session.get(ProlificCall, doubt.id), "not-sent", who="t")
        drain(recruiting_study, client)
    assert _row(app, doubt.id).state == "done" and fake.count("pay") == 1
    assert [
        s["bonus_payments"] for s in fake.submissions.values() if s["participant_id"] == pid
    ] == [[250]]


def test_a_cancelled_decision_can_be_taken_again(app, prolific_env, recruiting_study, published):
    fake = prolific_env
    sid, _ = _submitted(app, fake, recruiting_study, published, submit=False)
    with app.app_context():
        study = db.session.get(Study, recruiting_study)
        ((call, _),) = decide(study, [Decision(sid, "approve")], who="t")
        with pytest.raises(InputError, match="already has a decision: approve"):
            decide(study, [Decision(sid, "return", reasons=("Withdrew consent",))], who="t")
        assert resolve(call, "cancel", who="t") == "cancelled"
        ((again, new),) = decide(study, [Decision(sid, "approve")], who="t")
        assert new and again.id != call.id
        assert (
            db.session.scalar(
                sa.select(sa.func.count(ProlificCall.id)).where(ProlificCall.kind == "approve")
            )
            == 2
        )
