"""Browser test of the adaptive design end to end: two participants take an eight-condition
study in Debian's chromium; every vote's answer brings the pair the scheduler chose
(``app/web/study/adaptive.py``) without a trial page between pairs, and no clip is preloaded
before its pair is known."""

from __future__ import annotations

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Stimulus, Study, Trial, Vote
from tests.support.browser import (
    DESKTOP,
    ready_to_vote,
    shown_trial_id,
    trial_page_loads,
    until_gone,
)
from tests.support.studies import EIGHT_CONDITIONS

pytestmark = pytest.mark.browser


def _take_part(live_server, chromium, slug, pid, shots_dir=None):  # noqa: ANN001
    context = chromium.new_context(viewport=DESKTOP)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    loads = trial_page_loads(page)
    videos: list[str] = []
    page.on("request", lambda r: videos.append(r.url) if "/video/" in r.url else None)
    clicked: dict[int, str] = {}
    try:
        page.goto(f"{live_server.url}/s/{slug}?PROLIFIC_PID={pid}&STUDY_ID=st&SESSION_ID=se")
        page.click("text=I agree")
        page.wait_for_url("**/instructions")
        ready_to_vote(page)  # the practice pair
        page.keyboard.press("1")
        page.click("#start")
        step = 0
        while "/trial" in page.url:
            page.wait_for_selector(".player[data-trial-id]")
            trial = shown_trial_id(page)
            assert page.get_attribute(".player", "data-preload-url") is None
            ready_to_vote(page)
            if step == 3 and shots_dir is not None:
                page.screenshot(path=shots_dir / "participant-trial-adaptive.png")
            choice = ("left", "right", "undecided")[step % 3]
            page.click(f'.vote[data-choice="{choice}"]')
            clicked[trial] = choice
            until_gone(page, trial)
            page.wait_for_load_state()
            step += 1
        page.wait_for_url("**/done")
        assert page.inner_text("#completion-code") == "DONE-123"
    finally:
        context.close()
    assert errors == []
    assert len(loads) == 1 + 1, loads  # the first trial page and the one after the last vote
    return clicked, videos


def test_two_participants_take_an_adaptive_study(live_server, browser, shots):  # noqa: F811
    study_id = live_server.study(design="adaptive", extra=EIGHT_CONDITIONS)
    with live_server.app.app_context():
        slug = db.session.get(Study, study_id).slug
    for pid in ("ad-1", "ad-2"):
        clicked, videos = _take_part(live_server, browser, slug, pid, shots)
        with live_server.app.app_context():
            person = db.session.scalar(
                sa.select(Participant).where(Participant.prolific_pid == pid)
            )
            assert person.finished_at is not None
            rows = db.session.execute(
                sa.select(Trial.id, Stimulus.left_id, Stimulus.right_id, Vote.choice)
                .join(Stimulus, Stimulus.id == Trial.stimulus_id)
                .join(Vote, Vote.trial_id == Trial.id)
                .where(Trial.participant_id == person.id, Trial.kind == "trial")
            ).all()
        assert {r[0]: r[3] for r in rows} == clicked
        assert len(rows) == 14 and len({frozenset(r[1:3]) for r in rows}) == 14
        # each clip was fetched as the trial it belongs to: one trial's video at a time
        played = {int(u.rsplit("/", 1)[1].split("?")[0]) for u in videos if "/video/" in u}
        assert set(clicked) <= played
