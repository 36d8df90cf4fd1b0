"""Browser tests of the clips' renditions: chromium made into a browser without H.264 (as
WebKitGTK without its codec plugins is) by a script that runs before the page's, and by MP4s
that arrive as bytes no decoder takes. With a WebM beside every MP4 the participant takes the
whole study from the WebMs; with nothing it can play, the session ends on a page in the study's
language that says which browsers work, and the participant's list slot goes back at once.
Debian's chromium through Playwright against a live server."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, StudyList, Vote
from tests.conftest import create_test_study
from tests.support.studies import study_slug

pytestmark = pytest.mark.browser

DESKTOP = {"width": 1366, "height": 768}

#: A browser that plays no H.264 (``canPlayType`` rules the MP4 out, as WebKitGTK's does
#: without its codec plugins) or, with ``window.name`` "says maybe", one that claims it might
#: and finds out only from the file (as a Linux Firefox without the system's codecs does for a
#: bare "video/mp4"). "no webm" rules the WebM out as well.
NO_H264 = """
(() => {
  const asked = HTMLMediaElement.prototype.canPlayType;
  HTMLMediaElement.prototype.canPlayType = function (type) {
    if (/^video\\/mp4/i.test(type)) return window.name === "says maybe" ? "maybe" : "";
    if (/^video\\/webm/i.test(type)) return window.name === "no webm" ? "" : "maybe";
    return asked.call(this, type);
  };
})();
"""


def _undecodable(route) -> None:
    """A clip's answer as the server sends it, with bytes no decoder takes: the browser
    refuses it as a format it cannot play (MEDIA_ERR_SRC_NOT_SUPPORTED)."""
    route.fulfill(
        status=200,
        body=b"\x00\x00\x00\x18ftypmp42" + bytes(4000),
        headers={"Content-Type": "video/mp4", "Accept-Ranges": "bytes"},
    )


def _browser(chromium, behaviour: str):
    context = chromium.new_context(viewport=DESKTOP)
    context.add_init_script(f"window.name = {behaviour!r};\n" + NO_H264)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    asked: list[str] = []
    page.on("request", lambda r: asked.append(r.url) if "/api/" not in r.url else None)
    # every MP4 (practice, trials) arrives undecodable
    page.route(re.compile(r".*/(video/\d+|practice\.mp4)$"), _undecodable)
    return context, page, errors, asked


@pytest.mark.parametrize("behaviour", ["says no", "says maybe"])
def test_a_browser_without_h264_takes_the_study_from_the_webm(
    live_server, browser, tmp_path, tiny_video, tiny_webm, behaviour
):
    study_id = create_test_study(
        live_server.app, tmp_path, tiny_video, webm=tiny_webm, design="all_ordered"
    )
    context, page, errors, asked = _browser(browser, behaviour)
    voted = 0
    try:
        page.goto(f"{live_server.url}/s/{study_slug(live_server.app, study_id)}")
        page.click("text=I agree")
        page.wait_for_url("**/instructions")
        # the practice pair plays, from its WebM
        page.wait_for_selector(".play:not([disabled])")
        assert page.eval_on_selector("video", "v => v.currentSrc").endswith("/practice.webm")
        page.click("#start")
        while "/trial" in page.url:
            page.wait_for_selector(".player[data-trial-id]")
            trial = page.get_attribute(".player", "data-trial-id")
            page.wait_for_selector(".play:not([disabled])")
            shown = page.eval_on_selector("video", "v => v.currentSrc")
            assert shown.endswith(f"/webm/{trial}"), shown
            page.click(".play")
            page.wait_for_selector(".vote:not([disabled])")
            page.click('.vote[data-choice="left"]')
            voted += 1
            page.wait_for_selector(f'.player[data-trial-id="{trial}"]', state="detached")
            if "/done" in page.url or page.locator(".done").count():
                break
        page.wait_for_url("**/done")
    finally:
        context.close()
    assert errors == []
    mp4s = [url for url in asked if re.search(r"/(video/\d+|practice\.mp4)$", url)]
    # a browser that rules H.264 out never asks for an MP4; one that says "maybe" asks once per
    # clip, is refused, and asks for its WebM (the next clip's preload is the WebM already)
    assert mp4s == [] if behaviour == "says no" else len(mp4s) >= 1
    with live_server.app.app_context():
        person = db.session.scalar(sa.select(Participant))
        assert person.finished_at is not None and person.excluded_at is None
        assert db.session.scalar(sa.select(sa.func.count(Vote.id))) == voted >= 2


@pytest.mark.parametrize(
    "language, title, behaviour",
    [
        ("en", "This browser cannot play the study's videos", "no webm"),
        ("ar", "لا يستطيع هذا المتصفح تشغيل مقاطع الفيديو الخاصة بالدراسة", "says maybe"),
    ],
)
def test_a_browser_that_plays_no_rendition_ends_on_a_page_that_says_so(
    live_server, browser, tmp_path, tiny_video, tiny_webm, shots, language, title, behaviour
):
    """No rendition offered plays: ruled out by ``canPlayType`` (English study), or each one
    tried and refused as a format the browser cannot play (Arabic study: the WebM too arrives
    undecodable). No "retrying" forever: the final page, in the study's language, and the
    list slot is free for the next participant before any idle limit."""
    study_id = create_test_study(
        live_server.app, tmp_path, tiny_video, webm=tiny_webm, extra=f'language = "{language}"'
    )
    context, page, errors, _ = _browser(browser, behaviour)
    page.route(re.compile(r".*/(webm/\d+|practice\.webm)$"), _undecodable)
    try:
        page.goto(f"{live_server.url}/s/{study_slug(live_server.app, study_id)}")
        page.click("form .primary")
        page.wait_for_url("**/unplayable")
        assert page.inner_text("h1") == title
        assert page.get_attribute("html", "lang") == language
        assert page.get_attribute("html", "dir") == ("rtl" if language == "ar" else "ltr")
        text = page.inner_text("main")
        for name in ("Chrome", "Edge", "Firefox", "Safari"):
            assert name in text
        page.screenshot(path=shots / f"participant-unplayable-{language}.png", full_page=True)
        if os.environ.get("FACEPAIR_SCREENSHOTS"):
            assert Path(shots / f"participant-unplayable-{language}.png").is_file()
        # the study link again: the same final page, not the trials
        page.goto(f"{live_server.url}/s/{study_slug(live_server.app, study_id)}")
        page.wait_for_url("**/unplayable")
    finally:
        context.close()
    assert errors == []
    with live_server.app.app_context():
        person = db.session.scalar(sa.select(Participant))
        assert person.exclusion_reason == "browser cannot play the clips (no H.264 or WebM/VP9)"
        assert person.dropped_at is not None
        assert person.environment["browser"] == "Headless Chrome"
        held = db.session.scalar(
            sa.select(sa.func.sum(StudyList.n_assigned)).where(StudyList.study_id == study_id)
        )
        assert held == 0
