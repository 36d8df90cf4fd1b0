"""axe-core in the browser on every page type, the experimenter's and the participant's: no
violation of WCAG 2.2 A/AA or axe's best practices, whatever its impact
(``tests/support/axe.py`` gets axe-core from the npm registry at set-up time)."""

from __future__ import annotations

import pytest

from app.web.extensions import db
from app.web.models import Study, Trial
from tests.conftest import ParticipantActions
from tests.support.axe import axe_script, violations
from tests.support.browser import DESKTOP, PHONE, log_in
from tests.support.questionnaire import BEFORE, QUESTIONS, answer_page

pytestmark = pytest.mark.browser

PARTICIPANT_SIDE = (
    QUESTIONS
    + """
[answer]
scale = 5
reasons = ["lips", "head"]

[attention]
max_failed = 3

[viewing]
min_face_px = 10
"""
)


def _answer(actions: ParticipantActions, page: str, **values) -> None:
    assert answer_page(actions.client, actions.token, page, **values).status_code == 302


def _finish(app, actions: ParticipantActions) -> None:
    while (trial := actions.current_trial()) is not None:
        with app.app_context():
            kind = db.session.get(Trial, trial).kind
        extra = {} if kind == "catch" else {"strength": 2, "reasons": ["lips"]}
        actions.vote(
            trial,
            "undecided" if kind == "catch" else "left",
            **({"strength": 0} if kind == "catch" else extra),
        )


def test_every_page_type_passes_axe(live_server, browser, shots):
    script = axe_script()
    app, url = live_server.app, live_server.url
    live_server.user()
    study_id = live_server.study(design="all_ordered", catch=1, extra=PARTICIPANT_SIDE)
    empty_id = live_server.study(design="all_ordered", status="closed")
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
        empty_slug = db.session.get(Study, empty_id).slug
    done = ParticipantActions(app.test_client(), app)
    done.join(slug)
    _answer(done, "before", **BEFORE)
    _finish(app, done)
    midway = ParticipantActions(app.test_client(), app)
    midway.join(slug)
    _answer(midway, "before", **BEFORE)
    answered = ParticipantActions(app.test_client(), app)
    answered.join(slug)
    _answer(answered, "before", **BEFORE)
    _finish(app, answered)
    _answer(answered, "after", hours="3")
    fresh = ParticipantActions(app.test_client(), app)
    fresh.join(slug)
    found: list[str] = []
    for viewport in (DESKTOP, PHONE):
        context = browser.new_context(viewport=viewport, bypass_csp=True)
        page = context.new_page()
        try:
            participant_pages = [
                f"/s/{slug}",
                f"/p/{midway.token}/instructions",
                f"/p/{midway.token}/trial",
                f"/p/{done.token}/questions/after",
                f"/p/{answered.token}/done",
                f"/p/{fresh.token}/questions/before",
                f"/s/{empty_slug}",  # closed: unavailable
                "/p/no-such-token/trial",  # the error page
                "/experimenter/login",
            ]
            for path in participant_pages:
                page.goto(url + path)
                found += violations(page, script)
                if viewport is PHONE and path.endswith("/questions/before"):
                    page.screenshot(path=shots / "participant-questionnaire.png", full_page=True)
            log_in(page, url)
            page.wait_for_selector("text=New study")
            experimenter_pages = [
                "/experimenter/studies",
                "/experimenter/studies/new",
                f"/experimenter/studies/{study_id}",
                f"/experimenter/studies/{study_id}/monitor",
                "/experimenter/account",
                f"/experimenter/studies/{empty_id}/report/",  # not written yet
            ]
            for path in experimenter_pages:
                page.goto(url + path)
                found += violations(page, script)
            if viewport is DESKTOP:  # the report, once
                page.goto(f"{url}/experimenter/studies/{study_id}")
                page.click("text=Close study")
                page.wait_for_selector(".badge-closed")
                page.goto(f"{url}/experimenter/studies/{study_id}/report/")
                assert "Answer details" in page.content()
                found += violations(page, script)
        finally:
            context.close()
    assert not found, "\n".join(sorted(set(found)))
