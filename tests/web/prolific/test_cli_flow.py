"""The whole flow against the fake Prolific from the CLI: publish -> submissions -> webhook and
polling -> review -> approve -> bonus -> pay -> top-up, once as it should go and once with a
crash injected at each point of every call (after its row is written, after it is claimed,
after a payment's baseline is kept, after Prolific answered): no call is sent twice, none is
lost."""

from __future__ import annotations

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant
from app.web.prolific import outbox
from app.web.prolific.models import ProlificCall, ProlificStudy
from tests.support.fake_prolific import TOKEN
from tests.support.studies import study_slug
from tests.web.prolific.conftest import cli, take_part

pytestmark = pytest.mark.slow


class Crash(BaseException):
    """The process dies here (not an Exception: nothing catches it)."""


def crash_once_at(monkeypatch, point: str) -> set[int]:
    """Make every call crash the first time it reaches ``point``; returns the ids crashed."""
    crashed: set[int] = set()

    def checkpoint(name: str, call: ProlificCall) -> None:
        if name == point and call.id not in crashed:
            crashed.add(call.id)
            raise Crash(f"{point} #{call.id}")

    monkeypatch.setattr(outbox, "checkpoint", checkpoint)
    return crashed


def until_done(*args: str):  # type: ignore[no-untyped-def]
    """Run the command again after each crash, as an operator (or a supervisor) would."""
    for _ in range(20):
        try:
            return cli(*args)
        except Crash:
            continue
    raise AssertionError(f"{args} never finished")


def _calls(app, study_id: int) -> list[ProlificCall]:
    with app.app_context():
        rows = db.session.scalars(
            sa.select(ProlificCall)
            .where(ProlificCall.study_id == study_id)
            .order_by(ProlificCall.id)
        ).all()
        db.session.expunge_all()
        return list(rows)


@pytest.mark.parametrize("crash", [None, "written", "claimed", "prepared", "sent"])
def test_the_flow_from_the_cli_sends_each_call_once(
    crash, app, prolific_env, recruiting_study, monkeypatch, tmp_path
):
    fake, sid = prolific_env, recruiting_study
    crashed = crash_once_at(monkeypatch, crash) if crash else set()

    published = until_done("publish", str(sid), "--yes")
    assert published.exit_code == 0, published.output
    assert "cost: 4 places x 1.50 GBP = 6.00 GBP in rewards; 8.52 GBP with" in published.output
    with app.app_context():
        prolific_id = db.session.scalar(sa.select(ProlificStudy.prolific_id))
    study = fake.studies[prolific_id]
    assert study["status"] == "ACTIVE" and study["reward"] == 150
    assert study["external_study_url"] == (
        f"https://facepair.example.org/s/{study_slug(app, sid)}?PROLIFIC_PID={{{{%PROLIFIC_PID%}}}}"
        "&STUDY_ID={{%STUDY_ID%}}&SESSION_ID={{%SESSION_ID%}}"
    )
    assert study["completion_codes"][0]["code"] == "DONE-123"

    # four participants: one fine, one fails the catch trial, one returns, one stops early
    people = [fake.start(prolific_id) for _ in range(4)]
    (s1, p1), (s2, p2), (s3, p3), (s4, p4) = people
    take_part(app, sid, prolific_id, s1, p1)
    second = take_part(app, sid, prolific_id, s2, p2, catch="left")
    third = take_part(app, sid, prolific_id, s3, p3, finish=False)
    fourth = take_part(app, sid, prolific_id, s4, p4, finish=False)
    for submission in (s1, s2, s4):
        fake.submit(submission, "DONE-123")
    fake.set_status(s3, "RETURNED")

    # the webhook tells of the return; a replay and a forgery change nothing
    client = app.test_client()
    headers, body = fake.event("submission.status.change", s3, "RETURNED", participant_id=p3)
    answer = client.post(
        "/api/v1/prolific/webhook", data=body, headers=headers, base_url="https://x"
    )
    assert answer.status_code == 200 and f"P{third:04d} returned" in answer.json["status"]
    again = client.post(
        "/api/v1/prolific/webhook", data=body, headers=headers, base_url="https://x"
    )
    assert again.status_code == 200 and again.json["status"] == "duplicate"
    forged = dict(headers, **{"X-Event-ID": "other", "X-Prolific-Request-Signature": "AAAA"})
    refused = client.post(
        "/api/v1/prolific/webhook", data=body, headers=forged, base_url="https://x"
    )
    assert refused.status_code == 401
    with app.app_context():
        returned = db.session.scalar(sa.select(Participant).where(Participant.prolific_pid == p3))
        assert returned.exclusion_kind == "returned"

    # polling finds the rest
    polled = until_done("sync", str(sid))
    assert polled.exit_code == 0 and "4 submission(s) read" in polled.output

    reviewed = until_done(
        "review",
        *("--approve-all", "--yes", str(sid)),
        *("--reject", f"P{second:04d}", "--return", f"P{fourth:04d}"),
    )
    assert reviewed.exit_code == 0, reviewed.output
    assert "reject done" in reviewed.output and "return done" in reviewed.output
    assert fake.submissions[s1]["status"] == "APPROVED"
    assert fake.submissions[s2]["status"] == "REJECTED"
    assert fake.submissions[s4]["return_requested"] is not None
    assert fake.submissions[s3]["status"] == "RETURNED"

    bonuses = tmp_path / "bonuses.csv"
    bonuses.write_text(f"participant_id,amount\n{p1},1.50\n{p2},0.20\n")
    paid = until_done("bonus", str(sid), "--csv", str(bonuses), "--yes")
    assert paid.exit_code == 0, paid.output
    if crash == "prepared":
        # the payment may have gone out: nobody sends it again but a person who has looked
        (pay,) = [c for c in _calls(app, sid) if c.kind == "pay"]
        assert pay.state == "doubt" and fake.count("pay") == 0
        shown = cli("status", str(sid))
        assert "doubt" in shown.output and "resolve" in shown.output
        assert cli("resolve", str(pay.id), "--not-sent").exit_code == 0
    second = cli("bonus", str(sid), "--csv", str(bonuses), "--yes")
    assert second.exit_code == 0 and "nothing paid now" in second.output
    assert fake.count("pay") == 1
    assert fake.submissions[s1]["bonus_payments"] == [150]
    assert fake.submissions[s2]["bonus_payments"] == [20]

    raised = until_done("topup", str(sid), "--places", "6", "--yes")
    assert raised.exit_code == 0, raised.output
    assert fake.studies[prolific_id]["total_available_places"] == 6

    # every effect once; nothing left behind
    once = {k: n for k, n in fake.effects.items() if k[0] != "bonus"}
    assert once and set(once.values()) == {1}, fake.effects
    assert fake.count("bonus") <= (2 if crash == "sent" else 1)
    assert {("approve", s1), ("reject", s2), ("return", s4), ("publish", prolific_id)} <= set(once)
    assert ("top_up", prolific_id) in once and fake.count("create") == 1
    states = {c.kind: c.state for c in _calls(app, sid)}
    assert set(states.values()) == {"done"}, states
    if crash is not None and crash != "prepared":
        kinds = {c.kind for c in _calls(app, sid) if c.id in crashed}
        # every kind of call crashed once at this point (the review's return request is
        # written in the same commit as its rejection, which crashed after that commit)
        together = {"return"} if crash == "written" else set()
        assert kinds | together == set(states), kinds
    status = cli("status", str(sid))
    assert status.exit_code == 0 and f"study: {prolific_id} ACTIVE, 6 places" in status.output
    # the token is in no row and no output
    outputs = [published, polled, reviewed, paid, second, raised, status]
    assert not any(TOKEN in result.output for result in outputs)
    with app.app_context():
        for table in db.metadata.sorted_tables:
            assert TOKEN not in repr(db.session.execute(table.select()).all()), table.name
