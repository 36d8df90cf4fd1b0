"""Fixtures of the Prolific tests: the fake Prolific on loopback (``tests/support/fake_prolific``),
the environment pointing facepair's client at it, and a study with a ``[prolific]`` table whose
participants arrive from Prolific."""

from __future__ import annotations

import pytest
import sqlalchemy as sa
from click.testing import CliRunner

from app.cli import main
from app.web.extensions import db
from app.web.models import Study, Trial
from tests.conftest import ParticipantActions
from tests.support.fake_prolific import TOKEN, FakeProlific, running

PROLIFIC_TABLE = """
[prolific]
reward = 150
places = 4
minutes = 5
currency = "GBP"
bonus_per_check = "0.10"
"""
PUBLIC_URL = "https://facepair.example.org"


@pytest.fixture
def fake():
    service = FakeProlific()
    service.secret = "whsec-test-secret"
    with running(service) as base:
        service.url = base  # type: ignore[attr-defined]
        yield service
    assert not service.violations, service.violations


@pytest.fixture
def prolific_env(monkeypatch, app, fake):
    """facepair's client (CLI and app) pointed at the fake: no wait between retries, stale
    claims reconciled at once."""
    settings = {
        "DATABASE_URL": app.config["SQLALCHEMY_DATABASE_URI"],
        "MEDIA_ROOT": app.config["MEDIA_ROOT"],
        "PROLIFIC_API_URL": fake.url,
        "PROLIFIC_TOKEN": TOKEN,
        "PROLIFIC_BACKOFF_SECONDS": "0.001",
        "PROLIFIC_CLAIM_LEASE_SECONDS": "0",
        "PROLIFIC_RETRY_DELAY_SECONDS": "0",
        "FACEPAIR_PUBLIC_URL": PUBLIC_URL,
    }
    for key, value in settings.items():
        monkeypatch.setenv(key, value)
    monkeypatch.delenv("PROLIFIC_WORKSPACE_ID", raising=False)
    app.config["PROLIFIC_WEBHOOK_SECRET"] = fake.secret
    return fake


@pytest.fixture
def recruiting_study(app, web) -> int:
    """An open study with one catch trial and a ``[prolific]`` table (no redirect URL: finished
    participants go to Prolific's completion page)."""
    study_id = web.study(catch=1, extra=PROLIFIC_TABLE)
    with app.app_context():
        db.session.get_one(Study, study_id).redirect_url = ""
        db.session.commit()
    return study_id


def draft(**overrides):  # type: ignore[no-untyped-def]
    """A valid ``CreateStudy`` body."""
    return {
        "name": "n",
        "description": "d",
        "external_study_url": "https://x.org/s/a?PROLIFIC_PID={{%PROLIFIC_PID%}}",
        "prolific_id_option": "url_parameters",
        "total_available_places": 2,
        "estimated_completion_time": 5,
        "reward": 100,
        "completion_codes": [
            {"code": "C1", "code_type": "COMPLETED", "actions": [{"action": "MANUALLY_REVIEW"}]}
        ],
        **overrides,
    }


def cli(*args: str, input: str | None = None):  # type: ignore[no-untyped-def]
    return CliRunner().invoke(main, ["prolific", *args], input=input)


def take_part(
    app,
    study_id: int,
    prolific_study: str,
    submission: str,
    pid: str,
    *,
    catch: str = "undecided",
    finish: bool = True,
) -> int:
    """A participant arriving from Prolific's link: consent, then every trial ("left", and
    ``catch`` on the catch trial); unfinished after one vote with ``finish=False``. Returns
    their number."""
    with app.app_context():
        slug = db.session.get_one(Study, study_id).slug
    person = ParticipantActions(app.test_client(), app)
    person.join(slug, f"PROLIFIC_PID={pid}&STUDY_ID={prolific_study}&SESSION_ID={submission}")
    while (trial := person.current_trial()) is not None:
        with app.app_context():
            kind = db.session.get_one(Trial, trial).kind
        answer = person.vote(trial, catch if kind == "catch" else "left")
        assert answer.status_code == 201, answer.get_data(as_text=True)
        if not finish:
            break
    with app.app_context():
        from app.web.models import Participant

        return db.session.scalars(
            sa.select(Participant.number).where(Participant.prolific_pid == pid)
        ).one()
