"""The periodic job: ``sync --all`` and ``watch`` take every study on Prolific and every study
whose outbox still holds calls; a study Prolific refuses is one line and exit code 1, and the
others go on."""

from __future__ import annotations

from types import SimpleNamespace

import sqlalchemy as sa

from app.commands import prolific as commands
from app.web.extensions import db
from app.web.models import Study
from app.web.prolific.models import ProlificCall, ProlificStudy
from app.web.prolific.recruit import Account, draft, recruiting_spec
from tests.web.prolific.conftest import PROLIFIC_TABLE, PUBLIC_URL, cli


def _waiting_draft(app, study_id: int) -> int:
    """The create call of a draft written while Prolific was away (nothing sent yet)."""
    with app.app_context():
        study = db.session.get_one(Study, study_id)
        spec = recruiting_spec(study, None, source="study file")
        link = f"{PUBLIC_URL}/s/{study.slug}"
        _, create = draft(study, spec, link, Account("ws", "GBP", 0), pilot=False, who="t")
        return create.id


def _state(app, call_id: int) -> str:
    with app.app_context():
        return db.session.get_one(ProlificCall, call_id).state


def test_sync_all_and_watch_send_what_waits_and_go_on_past_a_refusal(
    app, web, prolific_env, recruiting_study, monkeypatch
):
    fake = prolific_env
    monkeypatch.setenv("PROLIFIC_ATTEMPTS", "2")
    create = _waiting_draft(app, recruiting_study)
    # a second study whose Prolific study Prolific no longer knows (404 on every read)
    gone = web.study(extra=PROLIFIC_TABLE)
    with app.app_context():
        db.session.add(ProlificStudy(study_id=gone, prolific_id="0" * 24, status="ACTIVE"))
        db.session.commit()

    fake.storm = 10_000
    stormed = cli("sync", "--all")
    assert stormed.exit_code == 1
    assert f"study {gone}: Prolific: GET /api/v1/studies/{'0' * 24}/" in stormed.output
    assert "1 call(s) waiting" in stormed.output
    assert _state(app, create) == "pending" and fake.count("create") == 0

    fake.storm = 0
    slept: list[float] = []
    monkeypatch.setattr(commands, "time", SimpleNamespace(sleep=slept.append))
    watched = cli("watch", "--rounds", "2", "--every", "10")
    assert watched.exit_code == 0, watched.output
    assert slept == [10]
    assert watched.output.count(f"study {gone}: Prolific:") == 2  # each round, and on
    assert _state(app, create) == "done" and fake.count("create") == 1
    assert fake.count("publish") == 0  # publishing is still the experimenter's decision
    with app.app_context():
        made = db.session.scalar(
            sa.select(ProlificStudy).where(ProlificStudy.study_id == recruiting_study)
        )
        assert made.prolific_id in fake.studies


def test_sync_needs_a_study_or_all(prolific_env):
    assert cli("sync").exit_code == 2
    assert cli("sync", "1", "--all").exit_code == 2
