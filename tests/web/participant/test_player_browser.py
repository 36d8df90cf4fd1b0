"""Browser tests of the participant's player and its pages at desktop (1366x768), phone
(390x844, touch) and small-phone (300x640, touch) size: no dead end once the plays of a
``max_plays`` pair are used and the page reloaded, the reason tags brought into view, the Play
button's label and place, touch wording in the instructions and a consent button inside its
card. Debian's chromium driven by Playwright against a live server."""

from __future__ import annotations

from contextlib import contextmanager

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Vote
from tests.conftest import create_test_study, make_clip
from tests.support.browser import device_context, screenshot
from tests.support.studies import study_slug

pytestmark = pytest.mark.browser

DESKTOP = {"width": 1366, "height": 768}
PHONE = {"width": 390, "height": 844}
SMALL = {"width": 300, "height": 640}
SIZES = [("desktop", DESKTOP, False), ("phone", PHONE, True), ("small", SMALL, True)]
REASONS = """
[answer]
scale = 5
reasons = ["lips", "head", "timing"]
"""


@pytest.fixture(scope="module")
def long_clip(tmp_path_factory):
    """A 3 s clip: long enough to look at the player while it plays."""
    return make_clip(tmp_path_factory.mktemp("long") / "long.mp4", seconds=3)


def _press(page, selector: str, touch: bool) -> None:
    (page.tap if touch else page.click)(selector)


@contextmanager
def _trial(live_server, chromium, tmp_path, clip, viewport: dict, touch: bool, **toml):
    """A page on the first trial of a new study (``toml`` as for ``create_test_study``), its
    clip ready to play; the page's script errors must stay none."""
    study_id = create_test_study(live_server.app, tmp_path, clip, **toml)
    slug = study_slug(live_server.app, study_id)
    context = device_context(chromium, viewport, touch)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    try:
        page.goto(f"{live_server.url}/s/{slug}?PROLIFIC_PID=p-{slug}&STUDY_ID=st&SESSION_ID=se")
        _press(page, "text=I agree", touch)
        page.wait_for_url("**/instructions")
        _press(page, "#start", touch)
        page.wait_for_selector(".player[data-trial-id]")
        page.wait_for_selector(".play:not([disabled])")
        yield page
    finally:
        context.close()
    assert errors == []


def _ended(page) -> None:
    """Wait until the play just started has reached its end (the overlay comes back)."""
    page.wait_for_selector(".overlay", state="hidden")
    page.wait_for_selector(".overlay", state="visible")


@pytest.mark.parametrize("name, viewport, touch", SIZES[:2])
def test_used_plays_and_a_reload_still_let_the_participant_answer(
    live_server,
    browser,  # noqa: F811
    long_clip,
    tmp_path,
    name,
    viewport,
    touch,
):
    """max_plays = 2, both plays to the end, then a reload before voting: Play is disabled
    ("0 plays left") but the answers are not, by button or by key, and the vote is stored with
    the server's count of plays."""
    setup = (live_server, browser, tmp_path, long_clip, viewport, touch)
    with _trial(*setup, replay="max_plays", max_plays=2) as page:
        trial = int(page.get_attribute(".player", "data-trial-id"))
        for _ in range(2):
            page.wait_for_selector(".play:not([disabled])")
            _press(page, ".play", touch)
            _ended(page)
        page.reload()
        page.wait_for_selector(".plays-left:text('0 plays left')")
        assert page.get_attribute(".player", "data-plays") == "2"
        assert page.locator(".play").is_disabled()
        page.wait_for_selector(".vote:not([disabled])")
        assert "please answer" in page.inner_text(".hint")
        if touch:
            _press(page, '.vote[data-choice="right"]', touch)
        else:
            page.keyboard.press("ArrowRight")
        page.wait_for_selector(f'.player[data-trial-id="{trial}"]', state="detached")
    with live_server.app.app_context():
        vote = db.session.scalar(sa.select(Vote).where(Vote.trial_id == trial))
        assert (vote.choice, vote.plays, vote.response_ms) == ("right", 2, None)


@pytest.mark.parametrize("name, viewport, touch", SIZES)
def test_choosing_an_answer_brings_the_reason_tags_into_view(
    live_server,
    browser,  # noqa: F811
    tiny_video,
    tmp_path,
    name,
    viewport,
    touch,
):
    setup = (live_server, browser, tmp_path, tiny_video, viewport, touch)
    with _trial(*setup, extra=REASONS) as page:
        _press(page, ".play", touch)
        page.wait_for_selector(".vote:not([disabled])")
        _press(page, '.vote[data-choice="left"][data-strength="2"]', touch)
        # shown and brought into view in one step of the page's script
        page.wait_for_selector(".reasons:not([hidden])")
        screenshot(page, f"participant-reasons-{name}")
        box = page.locator(".reasons .confirm").bounding_box()
        assert box["y"] >= 0 and box["y"] + box["height"] <= viewport["height"], box
        assert box["x"] >= 0 and box["x"] + box["width"] <= viewport["width"], box


def test_play_button_is_centred(
    live_server,
    browser,  # noqa: F811
    tiny_video,
    tmp_path,
):
    """No play cap: the empty plays-left counter takes no room beside the Play button."""
    with _trial(live_server, browser, tmp_path, tiny_video, DESKTOP, False) as page:
        play = page.locator(".play").bounding_box()
        controls = page.locator(".controls").bounding_box()
        centre = controls["x"] + controls["width"] / 2
        assert play["x"] + play["width"] / 2 == pytest.approx(centre, abs=1)


def test_play_again_is_offered_only_after_the_first_play(
    live_server,
    browser,  # noqa: F811
    long_clip,
    tmp_path,
):
    with _trial(live_server, browser, tmp_path, long_clip, DESKTOP, False) as page:
        assert "again" not in page.inner_text(".play")
        page.click(".play")
        page.wait_for_selector(".overlay", state="hidden")
        assert "again" not in page.inner_text(".play")  # the first play is running
        page.wait_for_selector(".overlay", state="visible")
        assert page.inner_text(".play").startswith("Play again")


@pytest.mark.parametrize("name, viewport, touch", SIZES)
def test_instructions_speak_of_keys_on_desktops_and_of_taps_on_phones(
    live_server,
    browser,  # noqa: F811
    name,
    viewport,
    touch,
):
    slug = study_slug(live_server.app, live_server.study())
    context = device_context(browser, viewport, touch)
    page = context.new_page()
    try:
        page.goto(f"{live_server.url}/s/{slug}")
        screenshot(page, f"participant-consent-{name}")
        consent = page.locator("form input[type=submit], form button[type=submit]").bounding_box()
        card = page.locator(".card").bounding_box()
        # The consent button stays inside its card, the card inside the window.
        assert (
            consent["x"] >= card["x"]
            and consent["x"] + consent["width"] <= card["x"] + card["width"]
        ), (consent, card)
        assert page.evaluate("document.documentElement.scrollWidth") <= viewport["width"]
        _press(page, "text=I agree", touch)
        page.wait_for_url("**/instructions")
        screenshot(page, f"participant-instructions-{name}")
        text = page.inner_text("ul.keys")
        if touch:
            assert "Space" not in text and "Press" not in text, text
            assert page.locator("ul.keys kbd:visible").count() == 0
            assert "Tap Play" in text
            # The practice player speaks of taps as well.
            page.wait_for_selector(".overlay-text:text('Ready: tap Play')")
        else:
            assert "Space" in text and "Tap Play" not in text, text
        assert page.evaluate("document.documentElement.scrollWidth") <= viewport["width"]
    finally:
        context.close()
