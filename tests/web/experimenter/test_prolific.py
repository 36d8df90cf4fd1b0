"""The study's Prolific page (``app.web.experimenter.prolific``) and the bonus file: whatever an
experimenter types or pastes is done, or refused in one line; never a 5xx, and nothing the
fake Prolific's OpenAPI shapes refuse is ever sent. Property-based."""

from __future__ import annotations

from decimal import Decimal

import pytest
import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.trials.recruiting import MAX_BONUS
from app.web.extensions import db
from app.web.prolific.bonus import parse_bonus_csv
from app.web.prolific.models import ProlificStudy
from app.web.prolific.review import REJECTION_CATEGORIES
from tests.conftest import csrf_token, login
from tests.web.prolific.conftest import cli, take_part

TEXT = st.text(st.characters(min_codepoint=1, max_codepoint=0x2FF), max_size=60)
NUMBERISH = st.one_of(
    TEXT,
    st.integers(min_value=-(10**30), max_value=10**30).map(str),
    st.decimals(allow_nan=True, allow_infinity=True, places=3).map(str),
)
CSV_CELL = st.one_of(NUMBERISH, st.sampled_from(["participant_id", "amount", ""]))
CSV_TEXT = st.lists(st.lists(CSV_CELL, min_size=0, max_size=3).map(",".join), max_size=6).map(
    "\n".join
)


@given(text=CSV_TEXT | TEXT)
def test_any_bonus_file_is_read_or_refused_in_one_line(text):
    try:
        amounts = parse_bonus_csv(text, source="bonuses.csv")
    except InputError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("bonuses.csv")
        return
    for pid, amount in amounts.items():
        assert pid and Decimal("0") < amount <= MAX_BONUS


#: The page tests share one study across examples (the fixtures are function-scoped).
FORM = settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))


@pytest.fixture
def on_prolific(app, client, prolific_env, recruiting_study):
    """A published study with one submission awaiting review, and a logged-in experimenter's
    CSRF token for its Prolific page: (study id, submission id, Prolific ID, token)."""
    fake = prolific_env
    assert cli("publish", str(recruiting_study), "--yes").exit_code == 0
    with app.app_context():
        prolific_id = db.session.scalar(sa.select(ProlificStudy.prolific_id))
    sid, pid = fake.start(prolific_id)
    take_part(app, recruiting_study, prolific_id, sid, pid)
    fake.submit(sid, "DONE-123")
    login(client)
    token = csrf_token(client, f"/experimenter/studies/{recruiting_study}/prolific")
    return recruiting_study, sid, pid, token


@FORM
@given(
    csv=CSV_TEXT | TEXT,
    confirm=st.sampled_from(["y", "", "n"]),
    valid=st.booleans(),
    data=st.data(),
)
def test_any_bonus_form_is_answered_without_a_5xx(client, on_prolific, csv, confirm, valid, data):
    study_id, _, pid, token = on_prolific
    if valid:
        amount = data.draw(st.decimals(min_value="0.01", max_value="5", places=2))
        csv = f"{pid},{amount}\n{csv}"
    answer = client.post(
        f"/experimenter/studies/{study_id}/prolific/bonus",
        data={"csrf_token": token, "csv": csv, "confirm": confirm},
    )
    assert answer.status_code == 302


@FORM
@given(places=NUMBERISH, confirm=st.sampled_from(["y", ""]))
def test_any_places_are_answered_without_a_5xx(client, on_prolific, places, confirm):
    study_id, _, _, token = on_prolific
    answer = client.post(
        f"/experimenter/studies/{study_id}/prolific/topup",
        data={"csrf_token": token, "places": places, "confirm": confirm},
    )
    assert answer.status_code == 302


@FORM
@given(
    do=st.sampled_from(["approve", "approve-all", "reject", "return", "other", ""]),
    known=st.booleans(),
    other=TEXT,
    category=st.sampled_from(REJECTION_CATEGORIES) | TEXT,
    message=TEXT | st.text(min_size=100, max_size=300),
    reason=TEXT,
)
def test_any_review_form_is_answered_without_a_5xx(
    client, on_prolific, do, known, other, category, message, reason
):
    study_id, sid, _, token = on_prolific
    answer = client.post(
        f"/experimenter/studies/{study_id}/prolific/review",
        data={
            "csrf_token": token,
            "do": do,
            "submission": sid if known else other,
            "category": category,
            "message": message,
            "reason": reason,
        },
    )
    assert answer.status_code == 302
    assert client.get(f"/experimenter/studies/{study_id}/prolific").status_code == 200
