"""Browser tests: Debian's chromium driven by Playwright against a live server on a file-backed
SQLite database. A participant walks through a whole study (keyboard and mouse, a reload, a
double click, a lost connection); an experimenter creates a study and downloads the votes. The
stored votes must be exactly the clicked ones. Screenshots go to ``$FACEPAIR_SCREENSHOTS`` (or
the test's temporary folder)."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study, Trial, Vote
from tests.support.browser import (
    DESKTOP,
    PHONE,
    create_and_open,
    ready_to_vote,
    shown_trial_id,
    trial_page_loads,
    until_gone,
)

pytestmark = pytest.mark.browser


def test_pairs_go_on_in_place_with_their_instruction_progress_and_no_stale_resend(
    live_server, browser
):
    """After the first trial page every pair comes from the vote's answer: the bar's progress
    and the instructed check's "please choose" line follow each pair as the trial page would
    show them. The first vote is answered 503 and resent by its timer; when the connection
    later drops and comes back, nothing of that vote is sent again and the pair on screen
    stays as it is (a played clip, answers open)."""
    study_id = live_server.study(
        design="all_ordered", replay="play_to_end", catch=2, catch_kind="instructed"
    )
    with live_server.app.app_context():
        slug = db.session.get(Study, study_id).slug
    context = browser.new_context(viewport=DESKTOP)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    sent: list[int] = []  # the trial of every vote request

    def votes(route):
        sent.append(json.loads(route.request.post_data)["trial_id"])
        if len(sent) == 1:
            route.fulfill(status=503, headers={"Retry-After": "1"}, json={"error": "busy"})
        else:
            route.continue_()

    page.route("**/api/v1/votes", votes)
    pages = trial_page_loads(page)
    shown: list[tuple[str, str | None]] = []
    try:
        page.goto(f"{live_server.url}/s/{slug}?PROLIFIC_PID=pp-8&STUDY_ID=st-8&SESSION_ID=se-8")
        page.click("text=I agree")
        page.wait_for_url("**/instructions")
        page.click("#start")
        step = 0
        while "/trial" in page.url:
            page.wait_for_selector(".player[data-trial-id]")
            trial = shown_trial_id(page)
            with live_server.app.app_context():
                row = db.session.get(Trial, trial)
                kind, expected = row.kind, row.expected
                total = len([t for t in row.participant.trials if t.kind != "practice"])
            assert page.inner_text(".progress-text") == f"Pair {step + 1} of {total}"
            bar = page.locator("progress[aria-label=Progress]")
            assert (bar.get_attribute("value"), bar.get_attribute("max")) == (
                str(step),
                str(total),
            )
            instructed = page.locator(".instructed")
            if kind == "catch":
                assert instructed.inner_text() == f"For this pair, please choose {expected}."
            else:
                assert instructed.count() == 0
            shown.append((kind, expected))
            ready_to_vote(page)
            if step == 2:
                # The connection drops and comes back: the first vote's resend, long done,
                # is not sent again, and this pair stays on screen as it is.
                context.set_offline(True)
                context.set_offline(False)
                # A grace period for a wrong resend to go out (what is checked is that nothing
                # happens, so no state of the page marks its end; a busy host can only make
                # the check weaker, never fail it).
                page.wait_for_timeout(500)
                assert shown_trial_id(page) == trial
                assert page.locator(".vote:not([disabled])").count() == 3
            page.click(f'.vote[data-choice="{expected if kind == "catch" else "left"}"]')
            until_gone(page, trial)
            step += 1
        page.wait_for_url("**/done")
    finally:
        context.close()
    assert errors == []
    assert sent[0] == sent[1] and len(sent) == len(set(sent)) + 1, sent  # one resend, once
    assert sum(kind == "catch" for kind, _ in shown) == 2
    assert len(pages) == 2, pages  # the first pair's page, and the one the last vote opens


def test_participant_walks_through_a_whole_study(live_server, browser, shots):
    study_id = live_server.study(design="all_ordered", replay="play_to_end", catch=1)
    with live_server.app.app_context():
        slug = db.session.get(Study, study_id).slug
    context = browser.new_context(viewport=DESKTOP)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    clicked: dict[int, str] = {}
    try:
        page.goto(f"{live_server.url}/s/{slug}?PROLIFIC_PID=pp-9&STUDY_ID=st-9&SESSION_ID=se-9")
        page.screenshot(path=shots / "participant-consent.png")
        page.keyboard.press("Enter")  # the agree button has the focus
        page.wait_for_url("**/instructions")
        # The practice pair, keyboard only; its answer is not stored.
        ready_to_vote(page)
        page.keyboard.press("1")
        page.wait_for_selector("text=Practice answer: left")
        page.screenshot(path=shots / "participant-instructions.png", full_page=True)
        page.click("#start")
        step = 0
        while "/trial" in page.url:
            page.wait_for_selector(".player[data-trial-id]")
            trial = shown_trial_id(page)
            if step == 1:
                # Reload in the middle: the same trial comes back.
                page.reload()
                assert shown_trial_id(page) == trial
            ready_to_vote(page)
            if step == 0:
                page.screenshot(path=shots / "participant-trial-desktop.png")
            choice = ("left", "right", "undecided")[step % 3]
            if step == 2:
                page.dblclick(f'.vote[data-choice="{choice}"]')  # a double click
            elif step == 3:
                # The connection drops: the page keeps the vote, says so, and sends it later.
                context.set_offline(True)
                page.keyboard.press("2")
                choice = "right"
                page.wait_for_selector(".status-offline")
                assert "kept on this page" in page.inner_text(".status")
                # The banner, pinned to the top, covers neither the question nor the progress.
                banner = page.locator(".status-offline").bounding_box()
                for covered in (".question", ".study-bar progress", ".progress-text"):
                    box = page.locator(covered).bounding_box()
                    assert box["y"] >= banner["y"] + banner["height"] - 1, (covered, box, banner)
                page.screenshot(path=shots / "participant-offline.png")
                context.set_offline(False)
            elif step % 2:
                page.keyboard.press(
                    {"left": "ArrowLeft", "right": "ArrowRight", "undecided": "ArrowDown"}[choice]
                )
            else:
                page.click(f'.vote[data-choice="{choice}"]')
            clicked[trial] = choice
            until_gone(page, trial)
            page.wait_for_load_state()
            step += 1
        page.wait_for_url("**/done")
        assert page.inner_text("#completion-code") == "DONE-123"
        assert page.get_attribute("#redirect", "href").startswith("https://example.org/complete")
        page.screenshot(path=shots / "participant-done.png")
    finally:
        context.close()
    assert errors == []
    with live_server.app.app_context():
        votes = db.session.scalars(sa.select(Vote)).all()
        assert {v.trial_id: v.choice for v in votes} == clicked
        assert len(votes) == len(clicked) == 5  # 4 ordered pairs + 1 catch trial
        assert all(v.plays >= 1 and v.response_ms is not None and v.response_ms >= 0 for v in votes)
        person = db.session.scalar(sa.select(Participant))
        assert person.prolific_pid == "pp-9" and person.finished_at is not None


def test_trial_page_on_a_phone(live_server, browser, shots):
    study_id = live_server.study(design="all_ordered")
    with live_server.app.app_context():
        slug = db.session.get(Study, study_id).slug
    context = browser.new_context(viewport=PHONE, is_mobile=True, has_touch=True)
    page = context.new_page()
    try:
        page.goto(f"{live_server.url}/s/{slug}")
        page.tap("text=I agree")
        page.tap("#start")
        page.wait_for_selector(".play:not([disabled])")
        page.tap(".play")
        page.wait_for_selector(".vote:not([disabled])")
        page.screenshot(path=shots / "participant-trial-phone.png", full_page=True)
        # Nothing wider than the screen; every answer button is a comfortable touch target.
        assert page.evaluate("document.documentElement.scrollWidth") <= PHONE["width"]
        for box in (page.locator(".vote").nth(i).bounding_box() for i in range(3)):
            assert box["height"] >= 44 and box["x"] >= 0 and box["x"] + box["width"] <= 390
        trial = shown_trial_id(page)
        page.tap('.vote[data-choice="right"]')
        until_gone(page, trial)
    finally:
        context.close()
    with live_server.app.app_context():
        assert [(v.trial_id, v.choice) for v in db.session.scalars(sa.select(Vote))] == [
            (trial, "right")
        ]


def test_experimenter_creates_a_study_and_downloads_votes(
    live_server, browser, shots, tmp_path, stub_pipeline
):
    live_server.user()
    toml = tmp_path / "study.toml"
    toml.write_text(live_server.toml(design="unordered_counterbalanced"))
    wav = live_server.write_wav(tmp_path / "s1.wav")
    context = browser.new_context(viewport=DESKTOP, accept_downloads=True)
    page = context.new_page()
    try:
        create_and_open(page, live_server.url, toml, wav)
        page.screenshot(path=shots / "experimenter-study.png", full_page=True)
        link = page.inner_text("#participant-link")

        # Two participants take part in their own browsers.
        clicked = []
        for choice in ("left", "right"):
            other = browser.new_context(viewport=DESKTOP)
            person = other.new_page()
            try:
                person.goto(link)
                person.click("text=I agree")
                person.click("#start")
                while "/trial" in person.url:
                    ready_to_vote(person)
                    trial = shown_trial_id(person)
                    person.click(f'.vote[data-choice="{choice}"]')
                    clicked.append(choice)
                    until_gone(person, trial)
                    person.wait_for_load_state()
            finally:
                other.close()

        page.click("text=Live monitor")
        assert page.inner_text("#stat-finished") == "2"
        page.screenshot(path=shots / "experimenter-monitor.png", full_page=True)
        page.go_back()
        with page.expect_download() as download:
            page.click("#export-votes")
        text = Path(download.value.path()).read_text()
    finally:
        context.close()
    rows = list(csv.DictReader(io.StringIO(text)))
    assert sorted(r["choice"] for r in rows) == sorted(clicked)
    with live_server.app.app_context():
        stored = db.session.execute(
            sa.select(Participant.number, Trial.position, Vote.choice)
            .join(Trial, Vote.trial_id == Trial.id)
            .join(Participant, Vote.participant_id == Participant.id)
        ).all()
    assert sorted((f"P{n:04d}", str(p), c) for n, p, c in stored) == sorted(
        (r["participant"], r["trial"], r["choice"]) for r in rows
    )
