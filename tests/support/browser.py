"""What the browser tests do on a page, in Debian's chromium through Playwright: the viewports
of the whole-flow tests, the experimenter's log-in and a study created and opened on the pages,
a participant's trial page waited on until a vote can be cast, and a new context at a device's
size. Nothing here is part of the application."""

from __future__ import annotations

import os
from pathlib import Path

from tests.conftest import PASSWORD

#: The viewports of the whole-flow browser tests (``tests/web/test_browser*.py``).
PHONE = {"width": 390, "height": 844}
DESKTOP = {"width": 1280, "height": 860}


def shown_trial_id(page) -> int:
    """The id of the trial whose player is on the page."""
    return int(page.locator(".player").get_attribute("data-trial-id"))


def until_gone(page, trial: int) -> None:
    """Wait until the trial's player has left the page (a selector wait: the pages' CSP
    forbids the eval a wait_for_function string needs)."""
    page.wait_for_selector(f'.player[data-trial-id="{trial}"]', state="detached")


def trial_page_loads(page) -> list[str]:
    """The trial pages ``page`` loads from now on (documents whose URL holds ``/trial``),
    filled in as it goes."""
    loads: list[str] = []
    page.on(
        "request",
        lambda r: (
            loads.append(r.url) if r.resource_type == "document" and "/trial" in r.url else None
        ),
    )
    return loads


def ready_to_vote(page) -> None:
    """Wait for the preload, play the clip (Space), wait until voting is allowed."""
    page.wait_for_selector(".play:not([disabled])")
    page.keyboard.press("Space")
    page.wait_for_selector(".vote:not([disabled])")


def log_in(page, url: str) -> None:
    """The test experimenter logs in on the login page."""
    page.goto(f"{url}/experimenter/")
    page.fill("input[name=email]", "exp@example.org")
    page.fill("input[name=password]", PASSWORD)
    page.click("input[type=submit]")


def create_and_open(page, url: str, toml, wav) -> None:
    """The test experimenter logs in, uploads the study file and its speech, generates the
    tracks, renders the clips (two) and opens recruitment, on the pages as a person would."""
    log_in(page, url)
    page.click("text=New study")
    page.set_input_files("input[name=file-study_file]", str(toml))
    page.set_input_files("input[name=file-media]", str(wav))
    page.click("input[name=file-submit]")
    page.wait_for_selector("text=Study created")
    page.click("text=1. Generate tracks")
    page.wait_for_selector(".job-done")
    page.click("text=2. Render clips")
    page.wait_for_selector("text=2 of 2 clips rendered")
    page.click("text=Open recruitment")
    page.wait_for_selector(".badge-open")


def device_context(chromium, viewport: dict, touch: bool):
    """A new context of ``chromium`` at ``viewport`` size, a phone's (mobile, touch) when
    ``touch``."""
    return chromium.new_context(viewport=viewport, is_mobile=touch, has_touch=touch)


def screenshot(page, name: str) -> None:
    """A screenshot to ``$FACEPAIR_SCREENSHOTS`` when that is set (to look at the page)."""
    if os.environ.get("FACEPAIR_SCREENSHOTS"):
        page.screenshot(path=Path(os.environ["FACEPAIR_SCREENSHOTS"]) / f"{name}.png")
