"""The three browser engines a participant-flow test runs in, behind one small page interface.

- ``chromium``: Debian's chromium through Playwright (the test session's ``browser`` fixture).
- ``firefox``: Debian's Firefox ESR through puppeteer-core over WebDriver BiDi, from a node
  process (:mod:`tests.support.puppeteer`; puppeteer-core comes from npm at set-up time).
- ``webkit``: WebKitGTK's MiniBrowser through WebKitWebDriver (Debian's webkit2gtk-driver) and
  Selenium. WebKitGTK has no headless mode (``WebKitWebDriver --help`` offers none), so each
  page gets a display of its own from Xvfb.
- ``webkit-no-h264``: the same WebKitGTK with its H.264 decoders put out of use (GStreamer's
  ``avdec_h264`` from gstreamer1.0-libav and ``openh264dec``, ranked NONE through
  ``GST_PLUGIN_FEATURE_RANK``), as it is on a system without those plugins: its
  ``canPlayType`` then rules the MP4 out and it must play the WebM renditions.

A test gets a page with :func:`open_page` and drives it with CSS selectors and JavaScript
expressions only, so the same steps run in every engine. Every wait is on the page's own state
(an element that appears or goes), bounded by :data:`tests.support.waits.WAIT_S`; no test
sleeps. Where an engine
or its driver is missing the test skips on a developer's machine and fails in CI (``CI=true``),
as :mod:`tests.support.rscript` does for R: ``make test`` installs them all. Nothing here is part
of the application.
"""

from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from tests.support.waits import WAIT_MS, WAIT_S

ENGINES = ("chromium", "firefox", "webkit", "webkit-no-h264")
#: GStreamer's H.264 decoders on Debian 12; ranked NONE, WebKitGTK finds none to play H.264 with.
NO_H264 = {"GST_PLUGIN_FEATURE_RANK": "avdec_h264:NONE,openh264dec:NONE"}
WEBKIT_DRIVER = "WebKitWebDriver"


def missing(what: str) -> None:
    """Skip the test, or fail it in CI: an engine must never drop out of the suite there."""
    message = f"{what}: `make test` installs the browsers from Debian and npm"
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(message)
    pytest.skip(message)


class Page:
    """One browser tab of an engine. Subclasses provide the primitive operations; the
    helpers built on :meth:`evaluate` are shared."""

    engine = ""
    #: The browser's name and version as its driver reports it.
    version = ""

    def goto(self, url: str) -> None:
        raise NotImplementedError

    def click(self, selector: str) -> None:
        """Click the first element ``selector`` matches, as a user's pointer would."""
        raise NotImplementedError

    def wait_for(self, selector: str, *, gone: bool = False) -> None:
        """Wait until an element matches ``selector`` (or, ``gone``, until none does)."""
        raise NotImplementedError

    def evaluate(self, expression: str) -> Any:
        """The JSON value of a JavaScript ``expression`` in the page."""
        raise NotImplementedError

    def errors(self) -> list[str] | None:
        """The page's uncaught script errors so far; None where the driver reports none."""
        return None

    def close(self) -> None:
        raise NotImplementedError

    def exists(self, selector: str) -> bool:
        return bool(self.evaluate(f"!!document.querySelector({json.dumps(selector)})"))

    def attribute(self, selector: str, name: str) -> str | None:
        return self.evaluate(
            f"document.querySelector({json.dumps(selector)}).getAttribute({json.dumps(name)})"
        )

    def text(self, selector: str) -> str:
        return self.evaluate(f"document.querySelector({json.dumps(selector)}).textContent.trim()")


class ChromiumPage(Page):
    """A Playwright page in a context of its own (cookies, storage and cache)."""

    engine = "chromium"

    def __init__(self, browser, viewport: dict[str, int]) -> None:
        self.version = f"chromium {browser.version}"
        self._context = browser.new_context(viewport=viewport)
        self._page = self._context.new_page()
        self._errors: list[str] = []
        self._page.on("pageerror", lambda exc: self._errors.append(str(exc)))

    def goto(self, url: str) -> None:
        self._page.goto(url, timeout=WAIT_MS)

    def click(self, selector: str) -> None:
        self._page.click(selector, timeout=WAIT_MS)

    def wait_for(self, selector: str, *, gone: bool = False) -> None:
        state = "detached" if gone else "attached"
        self._page.wait_for_selector(selector, state=state, timeout=WAIT_MS)

    def evaluate(self, expression: str) -> Any:
        return self._page.evaluate(expression)

    def errors(self) -> list[str] | None:
        return list(self._errors)

    def close(self) -> None:
        self._context.close()


@contextmanager
def xvfb(width: int, height: int) -> Iterator[str]:
    """An Xvfb display of its own (the server picks a free number); yields ``:N``."""
    server = shutil.which("Xvfb")
    if server is None:
        missing("Xvfb is not installed (Debian: xvfb), and WebKitGTK needs a display")
    assert server is not None
    read, write = os.pipe()
    process = subprocess.Popen(
        [server, "-displayfd", str(write), "-nolisten", "tcp", "-screen", "0",
         f"{width}x{height}x24"],
        pass_fds=(write,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip
    os.close(write)
    try:
        number = b""
        deadline = time.monotonic() + WAIT_S
        while not number.endswith(b"\n"):
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([read], [], [], left)[0]:
                raise AssertionError("Xvfb did not start")
            chunk = os.read(read, 16)
            if not chunk:
                raise AssertionError(f"Xvfb exited ({process.wait()})")
            number += chunk
        yield f":{number.decode().strip()}"
    finally:
        os.close(read)
        process.terminate()
        process.wait(10)


class WebKitPage(Page):
    """WebKitGTK's MiniBrowser through WebKitWebDriver and Selenium, on its own Xvfb display."""

    engine = "webkit"

    def __init__(self, viewport: dict[str, int], *, h264: bool = True) -> None:
        driver = shutil.which(WEBKIT_DRIVER)
        if driver is None:
            missing(f"{WEBKIT_DRIVER} is not installed (Debian: webkit2gtk-driver)")
        try:
            from selenium import webdriver
            from selenium.webdriver.remote.client_config import ClientConfig
            from selenium.webdriver.remote.remote_connection import RemoteConnection
        except ImportError:
            missing("selenium is not installed (pip install -e '.[test]')")
        width, height = viewport["width"], viewport["height"]
        self._display = xvfb(width, height)
        display = self._display.__enter__()
        self._service = webdriver.WebKitGTKService(
            executable_path=driver,
            env={**os.environ, "DISPLAY": display, **({} if h264 else NO_H264)},
            log_output=subprocess.DEVNULL,
        )
        try:
            # Selenium's WebKitGTK class hands the driver's address to RemoteConnection in a
            # way its own version deprecates (a warning, which fails the tests): the service
            # is started here and the session opened over a client_config instead.
            self._service.start()
            connection = RemoteConnection(
                client_config=ClientConfig(remote_server_addr=self._service.service_url)
            )
            self._driver = webdriver.Remote(
                command_executor=connection, options=webdriver.WebKitGTKOptions()
            )
            self._driver.set_window_size(width, height)
        except BaseException:
            self._service.stop()
            self._display.__exit__(None, None, None)
            raise
        caps = self._driver.capabilities
        self.version = f"{caps.get('browserName')} {caps.get('browserVersion')}"

    def goto(self, url: str) -> None:
        self._driver.get(url)

    def click(self, selector: str) -> None:
        from selenium.webdriver.common.by import By

        self._driver.find_element(By.CSS_SELECTOR, selector).click()

    def wait_for(self, selector: str, *, gone: bool = False) -> None:
        from selenium.common.exceptions import StaleElementReferenceException
        from selenium.webdriver.common.by import By
        from selenium.webdriver.support.wait import WebDriverWait

        # WebKitWebDriver can answer a search made while the page replaces the matched
        # element with "stale element": asked again at the next poll.
        WebDriverWait(
            self._driver,
            WAIT_S,
            poll_frequency=0.1,
            ignored_exceptions=(StaleElementReferenceException,),
        ).until(
            lambda d: bool(d.find_elements(By.CSS_SELECTOR, selector)) != gone,
            message=f"{'gone' if gone else 'there'} within {WAIT_S} s: {selector}",
        )

    def evaluate(self, expression: str) -> Any:
        return self._driver.execute_script(f"return ({expression});")

    def close(self) -> None:
        try:
            self._driver.quit()
        finally:
            self._service.stop()
            self._display.__exit__(None, None, None)


@contextmanager
def open_page(engine: str, request, viewport: dict[str, int]) -> Iterator[Page]:
    """A fresh page of ``engine`` (one of :data:`ENGINES`), closed on the way out. ``request``
    is the test's, for the chromium of the session's ``browser`` fixture."""
    page: Page
    if engine == "chromium":
        page = ChromiumPage(request.getfixturevalue("browser"), viewport)
    elif engine == "firefox":
        from tests.support.puppeteer import FirefoxPage

        page = FirefoxPage(viewport)
    elif engine in ("webkit", "webkit-no-h264"):
        page = WebKitPage(viewport, h264=engine == "webkit")
    else:
        raise ValueError(f"unknown browser engine: {engine}")
    try:
        yield page
    finally:
        page.close()
