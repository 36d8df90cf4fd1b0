"""Bonuses: the CSV (amounts in the study's currency, major unit), the rule (per correct check),
batches identified by their content (the same file twice is one batch), at most 200 a batch,
and IDs that did not take part refused before anything reaches Prolific."""

from __future__ import annotations

from decimal import Decimal

import pytest
import sqlalchemy as sa

from app.errors import InputError
from app.web.extensions import db
from app.web.models import Study
from app.web.prolific.bonus import batches, parse_bonus_csv, rule_bonuses
from app.web.prolific.models import ProlificCall, ProlificStudy, ProlificSubmission
from tests.web.prolific.conftest import take_part


def test_the_csv():
    amounts = parse_bonus_csv("participant_id,amount\n\nabc123, 1.5\ndef456,0.10\n")
    assert amounts == {"abc123": Decimal("1.50"), "def456": Decimal("0.10")}
    for text, message in (
        ("abc,1.234\n", "bonus CSV:1: expected an amount such as 1.50, got '1.234'"),
        ("abc,1\nabc,2\n", "bonus CSV:2: abc appears twice"),
        ("abc,1,2\n", "bonus CSV:1: expected participant_id,amount, got 3 cells"),
        ("abc,250\n", "bonus CSV:1: 250.00 is more than the 100 a bonus may be"),
        ("a b,1\n", "bonus CSV:1: expected a Prolific ID, got 'a b'"),
        ("\n", "bonus CSV: no bonuses in it"),
    ):
        with pytest.raises(InputError) as refused:
            parse_bonus_csv(text)
        assert str(refused.value) == message


def test_batches_by_content_and_strangers_refused(app, prolific_env, recruiting_study):
    with app.app_context():
        study = db.session.get(Study, recruiting_study)
        with pytest.raises(InputError, match="not on Prolific yet"):
            batches(study, {"a": Decimal("1")}, who="t")
        db.session.add(ProlificStudy(study_id=study.id, prolific_id="P1", currency="GBP"))
        pids = [f"{i:024x}" for i in range(250)]
        db.session.add_all(
            ProlificSubmission(study_id=study.id, submission_id=f"s{i}", prolific_pid=pid)
            for i, pid in enumerate(pids)
        )
        db.session.commit()
        with pytest.raises(InputError, match="1 Prolific ID.* did not take part .*: stranger1"):
            batches(study, {"stranger1": Decimal("1"), pids[0]: Decimal("1")}, who="t")
        amounts = {pid: Decimal("0.50") for pid in pids}
        first = batches(study, amounts, who="t")
        assert [len(b.bonuses) for b in first] == [200, 50] and all(b.new for b in first)
        again = batches(study, dict(reversed(list(amounts.items()))), who="t")
        assert [b.setup.id for b in again] == [b.setup.id for b in first]
        assert not any(b.new for b in again)
        assert db.session.scalar(sa.select(sa.func.count(ProlificCall.id))) == 2
        assert first[0].setup.payload["csv_bonuses"].splitlines()[0] == f"{pids[0]},0.50"


def test_the_rule_pays_per_correct_check(app, prolific_env, recruiting_study):
    take_part(app, recruiting_study, "P1", "s1", "aaa111")
    take_part(app, recruiting_study, "P1", "s2", "bbb222", catch="left")
    with app.app_context():
        study = db.session.get(Study, recruiting_study)
        assert rule_bonuses(study, Decimal("0.10")) == {"aaa111": Decimal("0.10")}
