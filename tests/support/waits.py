"""How long a browser test waits, and on what: the page's own state, never the clock.

Every wait of a browser test is for something the page shows (an element that appears or goes,
an attribute it sets, its media element's state) and is bounded by :data:`WAIT_S`, one generous
bound for every engine and driver: Playwright's contexts (:class:`WaitingBrowser`, the session's
``browser`` fixture), puppeteer-core's Firefox and Selenium's WebKitGTK
(:mod:`tests.support.engines`). A wait that is met returns at once, so the bound costs nothing
on a quiet host and only keeps a loaded one (two cores shared with a whole test run, where an
engine's first page or a clip's first load can take several seconds) from failing a test that
would have passed. ``$FACEPAIR_BROWSER_WAIT_S`` sets another bound, e.g. a short one to find a
broken wait quickly, or a longer one on a slower machine. Nothing here is part of the
application.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

#: The one bound on every wait for a page's state, in seconds.
WAIT_S = float(os.environ.get("FACEPAIR_BROWSER_WAIT_S", "60"))
#: The same bound in milliseconds, as Playwright and puppeteer-core take it.
WAIT_MS = WAIT_S * 1000
#: How often :func:`until` and :func:`until_page` look again, in milliseconds.
POLL_MS = 50


class WaitingBrowser:
    """A Playwright browser whose every new context waits at most :data:`WAIT_S` for anything
    (a selector, a navigation, an element to click), instead of Playwright's own 30 s; the rest
    is the browser's own."""

    def __init__(self, browser: Any) -> None:
        self._browser = browser

    def new_context(self, **options: Any) -> Any:
        context = self._browser.new_context(**options)
        context.set_default_timeout(WAIT_MS)
        return context

    def __getattr__(self, name: str) -> Any:
        return getattr(self._browser, name)


def until(page: Any, check: Callable[[], Any], what: str) -> Any:
    """Wait until ``check()`` holds, within :data:`WAIT_S`, and return its value: for a state
    the test sees from outside the page (a request the page made, a route holding a response).
    The page's events are handled meanwhile: Playwright's synchronous API handles them only
    while it is called, so it is asked to wait between two looks."""
    deadline = time.monotonic() + WAIT_S
    while not (found := check()):
        if time.monotonic() > deadline:
            raise AssertionError(f"not within {WAIT_S:g} s: {what}")
        page.wait_for_timeout(POLL_MS)
    return found


def until_page(page: Any, expression: str) -> Any:
    """Wait until the JavaScript ``expression`` is true in the page, within :data:`WAIT_S`, and
    return its value: for a state no selector can see (a media element's time or readiness).
    The participant pages' Content-Security-Policy forbids the eval that Playwright's
    ``wait_for_function`` needs; ``evaluate`` is not subject to it."""
    return until(page, lambda: page.evaluate(expression), expression)


def played(page: Any, seconds: float = 1.0) -> None:
    """Wait until the page's clip has played ``seconds`` (or to its end, if it is shorter): the
    player as a participant sees it once a play is under way."""
    until_page(
        page, f"(v => v.currentTime >= {seconds} || v.ended)(document.querySelector('video'))"
    )
