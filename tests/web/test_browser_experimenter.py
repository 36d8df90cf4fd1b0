"""Browser test of the experimenter's side, end to end: a study from the shipped
``app/data/examples/study.toml`` upload and one from the form; the form's study is piloted, opened,
taken by two participants (one fails a catch trial and is left out), closed, its PDF report
downloaded, duplicated and deleted. Debian's chromium through Playwright against a live server
on a file-backed SQLite database, as in ``tests/web/test_browser.py``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study, Trial
from tests.support.browser import (
    DESKTOP,
    log_in,
    ready_to_vote,
    shown_trial_id,
    until_gone,
)

pytestmark = pytest.mark.browser


def _take_part(browser, app, url: str, *, catch_answer: str) -> None:
    """A participant in their own browser: "left" on every real trial, ``catch_answer`` on
    the catch trials."""
    context = browser.new_context(viewport=DESKTOP)
    page = context.new_page()
    try:
        page.goto(url)
        if "/instructions" not in page.url:
            page.click("text=I agree")
        page.wait_for_url("**/instructions")
        page.click("#start")
        while "/trial" in page.url:
            ready_to_vote(page)
            trial = shown_trial_id(page)
            with app.app_context():
                kind = db.session.get(Trial, trial).kind
            page.click(f'.vote[data-choice="{catch_answer if kind == "catch" else "left"}"]')
            until_gone(page, trial)
            page.wait_for_load_state()
        page.wait_for_url("**/done")
    finally:
        context.close()


def test_an_experimenter_runs_a_study_from_start_to_end(
    live_server, browser, shots, tmp_path, stub_pipeline, repo_root
):
    live_server.user()
    wav = live_server.write_wav(tmp_path / "s1.wav")
    context = browser.new_context(viewport=DESKTOP, accept_downloads=True)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    try:
        log_in(page, live_server.url)

        # The shipped example, uploaded as it is with the two files it names.
        page.click("text=New study")
        page.set_input_files(
            "input[name=file-study_file]",
            str(repo_root / "app" / "data" / "examples" / "study.toml"),
        )
        page.set_input_files(
            "input[name=file-media]",
            [
                str(repo_root / "app" / "data" / "demo" / n)
                for n in ("speech.wav", "ground_truth.fap")
            ],
        )
        page.click("input[name=file-submit]")
        page.wait_for_selector("text=Study created")
        assert "Head and eyebrow motion of a talking face" in page.inner_text("h1")

        # The form: models ticked, one clip, one catch trial.
        page.goto(f"{live_server.url}/experimenter/studies/new")
        page.fill("input[name=web-title]", "Form study")
        page.check('input[name=web-models][value="none"]')
        page.check('input[name=web-models][value="random"]')
        page.set_input_files("input[name=web-audio]", str(wav))
        page.fill("input[name=web-catch_trials]", "1")
        page.click("input[name=web-submit]")
        page.wait_for_selector("text=Study created")
        study_id = int(page.url.rsplit("/", 1)[1])
        page.click("text=1. Generate tracks")
        page.wait_for_selector(".job-done")
        page.click("text=2. Render clips")
        page.wait_for_selector("text=clips rendered (stub)")

        # A pilot before opening: counted apart, and it freezes the stimuli.
        _take_part(
            browser, live_server.app, page.inner_text("#pilot-link"), catch_answer="undecided"
        )
        page.reload()
        assert page.locator("text=2. Render clips").is_disabled()
        page.click("text=Open recruitment")
        page.wait_for_selector(".badge-open")
        link = page.inner_text("#participant-link")
        assert page.input_value("#prolific-url") == (
            link + "?PROLIFIC_PID={{%PROLIFIC_PID%}}&STUDY_ID={{%STUDY_ID%}}"
            "&SESSION_ID={{%SESSION_ID%}}"
        )
        page.screenshot(path=shots / "experimenter-study-open.png", full_page=True)

        _take_part(browser, live_server.app, link, catch_answer="undecided")
        _take_part(browser, live_server.app, link, catch_answer="left")  # fails the catch

        page.click("text=Live monitor")
        table = page.inner_text("#participant-table")
        assert "pilot" in table and "failed a catch trial (0 of 1 passed)" in table
        assert page.inner_text("#stat-finished") == "2"  # the pilot is not counted
        page.screenshot(path=shots / "experimenter-monitor-participants.png", full_page=True)
        page.click("text=Back to the study")

        page.click("text=Close study")
        page.wait_for_selector(".badge-closed")
        response = page.request.get(
            f"{live_server.url}/experimenter/studies/{study_id}/report/report.pdf"
        )
        assert response.ok and response.body().startswith(b"%PDF")
        (shots / "experimenter-report.pdf").write_bytes(response.body())
        report = page.request.get(
            f"{live_server.url}/experimenter/studies/{study_id}/report/"
        ).text()
        assert "<h1>Form study</h1>" in report
        assert "1 participant cast" in report and "failed a catch trial" in report

        page.check("input[name=with_clips]")
        page.click("text=Duplicate study")
        page.wait_for_selector("text=Copied as")
        copy_id = int(page.url.rsplit("/", 1)[1])
        assert copy_id != study_id and "Form study (copy)" in page.inner_text("h1")

        page.goto(f"{live_server.url}/experimenter/studies/{study_id}")
        page.fill("#delete-study input[name=title]", "Form study")
        page.click("text=Delete study and all its data")
        page.wait_for_selector("text=Deleted 'Form study'")
        listing = page.inner_text("main") if page.locator("main").count() else page.content()
        assert re.search(r"Form study \(copy\)", listing)
    finally:
        context.close()
    assert errors == []
    with live_server.app.app_context():
        assert db.session.get(Study, study_id) is None
        copy = db.session.get(Study, copy_id)
        assert copy.status == "ready"
        assert db.session.scalar(sa.select(sa.func.count(Participant.id))) == 0
        media = Path(live_server.app.config["MEDIA_ROOT"])
        assert not (media / f"study-{study_id}").exists()
