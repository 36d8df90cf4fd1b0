"""Browser test of recruiting on Prolific from the study's page, against the fake Prolific on
loopback: draft, cost, publish; participants arrive from Prolific's link; a return reaches the
webhook over HTTP; sync; bulk approval and a rejection confirmed on the page; a bonus paid once
(the same lines again pay nothing); places raised only with the tick; axe-core finds nothing
on the page. Debian's chromium through Playwright against a live server on a file-backed
SQLite database, as in ``tests/web/test_browser.py``."""

from __future__ import annotations

import pytest
import requests
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study
from app.web.prolific.models import ProlificStudy
from tests.support.axe import axe_script, violations
from tests.support.browser import DESKTOP, log_in
from tests.support.fake_prolific import TOKEN, FakeProlific, running
from tests.web.prolific.conftest import PROLIFIC_TABLE, take_part

pytestmark = pytest.mark.browser


def test_an_experimenter_recruits_reviews_and_pays_on_prolific(
    live_server, browser, shots, monkeypatch
):
    fake = FakeProlific()
    fake.secret = "whsec-browser"
    app = live_server.app
    live_server.user()
    study_id = live_server.study(catch=1, extra=PROLIFIC_TABLE)
    with app.app_context():
        db.session.get(Study, study_id).redirect_url = ""
        db.session.commit()
    app.config.update(PROLIFIC_WEBHOOK_SECRET=fake.secret, PROLIFIC_WEBHOOK_HTTPS_ONLY=False)
    with running(fake) as prolific_url:
        for key, value in {
            "PROLIFIC_API_URL": prolific_url,
            "PROLIFIC_TOKEN": TOKEN,
            "PROLIFIC_BACKOFF_SECONDS": "0.001",
            "PROLIFIC_RETRY_DELAY_SECONDS": "0",
        }.items():
            monkeypatch.setenv(key, value)
        context = browser.new_context(viewport=DESKTOP, bypass_csp=True)  # axe is injected
        page = context.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        try:
            log_in(page, live_server.url)
            page.goto(f"{live_server.url}/experimenter/studies/{study_id}")
            page.click("#prolific-page")
            page.click("text=Create the draft on Prolific")
            assert page.inner_text("#prolific-cost") == "8.52 GBP"
            assert not violations(page, axe_script())  # the draft, its cost and the tick
            page.check("#publish-confirm")
            page.click("text=Publish on Prolific")
            assert page.inner_text("#prolific-live .prolific-status") == "ACTIVE"
            with app.app_context():
                prolific_id = db.session.scalar(sa.select(ProlificStudy.prolific_id))
            assert fake.studies[prolific_id]["status"] == "ACTIVE"

            (s1, p1), (s2, p2), (s3, p3) = (fake.start(prolific_id) for _ in range(3))
            take_part(app, study_id, prolific_id, s1, p1)
            rejected = take_part(app, study_id, prolific_id, s2, p2, catch="left")
            take_part(app, study_id, prolific_id, s3, p3, finish=False)
            fake.submit(s1, "DONE-123")
            fake.submit(s2, "DONE-123")
            fake.set_status(s3, "RETURNED")
            headers, body = fake.event(
                "submission.status.change", s3, "RETURNED", participant_id=p3
            )
            delivered = requests.post(
                f"{live_server.url}/api/v1/prolific/webhook", data=body, headers=headers, timeout=10
            )
            assert delivered.status_code == 200 and "returned" in delivered.json()["status"]
            with app.app_context():
                returned = db.session.scalar(
                    sa.select(Participant).where(Participant.prolific_pid == p3)
                )
                assert returned.exclusion_kind == "returned"

            page.click("text=Sync now")
            assert page.locator("#review-table tbody tr").count() == 3
            page.screenshot(path=str(shots / "experimenter-prolific.png"), full_page=True)
            assert not violations(page, axe_script())
            page.click("text=Approve every proposed approval")
            decision = page.locator(f"#decide-{s2}")
            decision.locator("summary").click()
            decision.locator("button:has-text('Reject')").click()
            assert "1 decision(s) written" in page.inner_text(".flash-ok")
            assert fake.submissions[s1]["status"] == "APPROVED"
            assert fake.submissions[s2]["status"] == "REJECTED" and rejected == 1

            page.fill("#bonus-form textarea", f"{p1},1.50\n")
            page.check("#bonus-form input[name=confirm]")
            page.click("text=Set up (and pay) the bonuses")
            assert "paying 1.50" in page.inner_text(".flash-ok")
            page.fill("#bonus-form textarea", f"{p1},1.50\n")
            page.check("#bonus-form input[name=confirm]")
            page.click("text=Set up (and pay) the bonuses")
            assert "nothing paid" in page.inner_text(".flash-ok")
            assert fake.count("pay") == 1 and fake.submissions[s1]["bonus_payments"] == [150]

            page.fill("#topup-form input[name=places]", "6")
            page.click("#topup-form button[type=submit]")  # unticked: the tick box is required
            assert fake.studies[prolific_id]["total_available_places"] == 4
            page.fill("#topup-form input[name=places]", "6")
            page.check("#topup-confirm")
            page.click("#topup-form button[type=submit]")
            assert fake.studies[prolific_id]["total_available_places"] == 6
            states = page.locator("#outbox-table tbody tr").evaluate_all(
                "rows => rows.map(r => r.dataset.kind + ':' + r.dataset.state)"
            )
            assert sorted(states) == sorted(
                [
                    "create:done",
                    "publish:done",
                    "approve:done",
                    "reject:done",
                    "bonus:done",
                    "pay:done",
                    "top_up:done",
                ]
            )
            assert not errors, errors
        finally:
            context.close()
    assert not fake.violations, fake.violations
    assert {n for n in fake.effects.values()} == {1}, fake.effects
