"""The participant's whole flow in the three browser engines participants use: chromium (through
Playwright), Firefox ESR (puppeteer-core over WebDriver BiDi) and WebKitGTK (WebKitWebDriver and
Selenium), all from Debian (tests/support/engines.py). In each, one participant takes a pair
study and then a rating study against a live server: consent, instructions, and every trial
played to its end, answered, and followed by the next trial in place (the page is not loaded
again: a mark left on the first trial's page is still there), up to the completion code. The
database must then hold each answer exactly once, as it was clicked, with the play counted.
Every clip has both renditions (MP4 and WebM), as the render job makes them: each engine must
play the one its ``canPlayType`` puts first (the MP4 where it has H.264, as Debian's three do
with their codecs installed; the WebM in a WebKitGTK without its GStreamer H.264 decoders, run
here as ``webkit-no-h264``). The browser name the participants are recorded under must be the
engine's own."""

from __future__ import annotations

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Rating, Vote
from tests.conftest import create_test_study
from tests.support.engines import ENGINES, open_page
from tests.support.studies import study_slug

pytestmark = pytest.mark.browser

DESKTOP = {"width": 1366, "height": 768}
#: Left on the first trial's page; a page load would take it away.
MARK = "window.facepairFirstPage"
VIDEO = "document.querySelector('video')"
#: The MP4's type as participant.js asks the browser about it.
H264 = 'video/mp4; codecs="avc1.640028, mp4a.40.2"'
#: The name each engine's participants are recorded under (app/web/study/useragent.py): its
#: own, not the one its User-Agent imitates (WebKitGTK says "Safari"); chromium started
#: headless says so in its User-Agent (``HeadlessChrome``).
RECORDED_AS = {
    "chromium": "Headless Chrome",
    "firefox": "Firefox",
    "webkit": "WebKitGTK",
    "webkit-no-h264": "WebKitGTK",
}


def _take_part(page, base: str, slug: str, pid: str, *, rating: bool) -> tuple[dict, set]:
    """One participant from consent to the completion code. Returns trial id -> the answer
    clicked (``left``/``right`` for a pair, the ACR level for a rating) and the renditions
    played (``mp4``, ``webm``)."""
    holder, answers = (".rater", ".level") if rating else (".player", ".vote")
    page.goto(f"{base}/s/{slug}?PROLIFIC_PID={pid}&STUDY_ID=st-1&SESSION_ID=se-1")
    page.click("form [name=agree]")
    page.wait_for("#start")
    page.click("#start")
    given: dict[int, int | str] = {}
    played: set[str] = set()
    while True:
        page.wait_for(f"{holder}[data-trial-id], #completion-code")
        if page.exists("#completion-code"):
            break
        trial = int(page.attribute(holder, "data-trial-id"))
        if given:
            assert page.evaluate(MARK) == slug, f"{page.engine}: trial {trial} loaded a page"
        else:
            page.evaluate(f"{MARK} = {slug!r}")
        page.wait_for(".play:not([disabled])")
        page.click(".play")
        # replay "play_to_end": the answers open only once the clip has played to its end
        page.wait_for(f"{answers}:not([disabled])")
        state = page.evaluate(f"[{VIDEO}.ended, {VIDEO}.played.length, {VIDEO}.currentSrc]")
        assert state[0] and state[1] >= 1, (page.engine, trial, state)
        renditions = {
            "mp4": page.attribute(holder, "data-video-url"),
            "webm": page.attribute(holder, "data-webm-url"),
        }
        played |= {kind for kind, url in renditions.items() if url and state[2].endswith(url)}
        step = len(given)
        if rating:
            answer: int | str = (4, 2, 5)[step % 3]
            page.click(f'.level[data-score="{answer}"]')
        else:
            answer = ("left", "right")[step % 2]
            page.click(f'.vote[data-choice="{answer}"]')
        given[trial] = answer
        page.wait_for(f'{holder}[data-trial-id="{trial}"]', gone=True)
    assert page.text("#completion-code") == "DONE-123"
    return given, played


@pytest.mark.parametrize("engine", ENGINES)
def test_a_pair_study_and_a_rating_study_taken_in_each_engine(
    engine, request, live_server, tmp_path, tiny_video, tiny_webm
):
    app = live_server.app
    pairs = create_test_study(
        app, tmp_path, tiny_video, webm=tiny_webm, design="all_ordered", replay="play_to_end"
    )
    ratings = create_test_study(
        app,
        tmp_path,
        tiny_video,
        webm=tiny_webm,
        design="rating",
        replay="play_to_end",
        catch_kind="instructed",
    )
    with open_page(engine, request, DESKTOP) as page:
        voted, pair_renditions = _take_part(
            page, live_server.url, study_slug(app, pairs), "pp-1", rating=False
        )
        rated, rating_renditions = _take_part(
            page, live_server.url, study_slug(app, ratings), "pp-2", rating=True
        )
        errors = page.errors()
        page.goto("about:blank")  # the done page would go on to the platform
        h264 = page.evaluate(f"document.createElement('video').canPlayType({H264!r})")
    assert errors in ([], None), errors
    # the variant without H.264 must be one, or it would test nothing of its own
    assert engine != "webkit-no-h264" or not h264, h264
    # the rendition participant.js chooses: the MP4 where the browser expects to play it
    assert pair_renditions | rating_renditions == {"mp4" if h264 else "webm"}, page.version
    assert len(pair_renditions) == len(rating_renditions) == 1  # one rendition a study
    assert len(voted) >= 2 and len(rated) == 2  # 2 conditions: the ordered pairs, both clips
    with app.app_context():
        votes = db.session.scalars(sa.select(Vote)).all()
        ratings_stored = db.session.scalars(sa.select(Rating)).all()
        people = db.session.scalars(sa.select(Participant)).all()
    assert sorted((v.trial_id, v.choice) for v in votes) == sorted(voted.items())
    assert sorted((r.trial_id, r.score) for r in ratings_stored) == sorted(rated.items())
    assert all(row.plays >= 1 for row in [*votes, *ratings_stored])
    assert len(people) == 2 and all(p.finished_at is not None for p in people)
    assert [(p.environment or {}).get("browser") for p in people] == [RECORDED_AS[engine]] * 2
