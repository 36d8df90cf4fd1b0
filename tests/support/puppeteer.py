"""Firefox for the browser tests: Debian's Firefox ESR driven over WebDriver BiDi by puppeteer-core.

puppeteer-core comes from the npm registry at test set-up time (``make test`` runs ``python -m
tests.support.puppeteer`` first, which installs the pinned version into ``.cache/puppeteer-core``
with ``PUPPETEER_SKIP_DOWNLOAD`` set); nothing of it is committed, and puppeteer-core itself
never downloads a browser: it starts the Firefox it is given. Debian has no geckodriver, so
Selenium cannot drive Firefox here; puppeteer-core speaks BiDi to Firefox directly.

:class:`FirefoxPage` runs ``puppeteer_bridge.cjs`` in node and sends it one JSON command a line.
Nothing here is part of the application.
"""

from __future__ import annotations

import json
import os
import queue
import shutil
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

from tests.support.engines import Page, missing
from tests.support.waits import WAIT_S

#: 24.x: the last series that runs on Debian 12's node 18 (25.x needs node 22).
PUPPETEER_VERSION = "24.43.1"
ROOT = Path(__file__).resolve().parents[2]
PREFIX = Path(os.environ.get("FACEPAIR_PUPPETEER_DIR", ROOT / ".cache" / "puppeteer-core"))
PACKAGE = PREFIX / "node_modules" / "puppeteer-core"
BRIDGE = Path(__file__).with_name("puppeteer_bridge.cjs")
FIREFOXES = ("firefox-esr", "firefox")
#: An answer the bridge owes takes at most a wait's bound and this much more (a page load).
SLACK_S = 30


def install() -> Path:
    """Install the pinned puppeteer-core into :data:`PREFIX` unless it is there; its folder.
    Raises ``RuntimeError`` with the reason when that cannot be done."""
    if _installed_version() == PUPPETEER_VERSION:
        return PACKAGE
    npm = shutil.which("npm")
    if npm is None:
        raise RuntimeError("npm is not installed (Debian: apt-get install npm)")
    PREFIX.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(
        [npm, "install", "--prefix", str(PREFIX), "--no-save", "--no-audit", "--no-fund",
         f"puppeteer-core@{PUPPETEER_VERSION}"],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        env={**os.environ, "PUPPETEER_SKIP_DOWNLOAD": "1"},
    )  # fmt: skip
    if done.returncode != 0 or _installed_version() != PUPPETEER_VERSION:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise RuntimeError(f"npm install puppeteer-core@{PUPPETEER_VERSION} failed: {last}")
    return PACKAGE


def _installed_version() -> str | None:
    try:
        return str(json.loads((PACKAGE / "package.json").read_text(encoding="utf-8"))["version"])
    except (OSError, ValueError, KeyError):
        return None


class FirefoxPage(Page):
    """One page of a headless Firefox of its own (a fresh profile), through the node bridge."""

    engine = "firefox"

    def __init__(self, viewport: dict[str, int]) -> None:
        firefox = next(filter(None, map(shutil.which, FIREFOXES)), None)
        if firefox is None:
            missing("Firefox is not installed (Debian: firefox-esr)")
        node = shutil.which("node")
        if node is None:
            missing("node is not installed (Debian: nodejs, with npm)")
        try:
            package = install()
        except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
            missing(f"puppeteer-core unavailable: {exc}")
        assert firefox is not None and node is not None
        self._process = subprocess.Popen(
            [node, str(BRIDGE), str(package), firefox, str(viewport["width"]),
             str(viewport["height"])],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )  # fmt: skip
        self._answers: queue.Queue[str] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        try:
            self.version = f"firefox {self._answer('start')}"
        except BaseException:
            self._stop()
            raise

    def _read(self) -> None:
        assert self._process.stdout is not None
        for line in self._process.stdout:
            self._answers.put(line)
        self._answers.put("")  # the bridge has exited

    def _answer(self, op: str) -> Any:
        try:
            line = self._answers.get(timeout=WAIT_S + SLACK_S)
        except queue.Empty:
            raise AssertionError(f"firefox: no answer to {op} in {WAIT_S + SLACK_S} s") from None
        if not line:
            raise AssertionError(f"firefox: the driver exited ({self._process.wait()})")
        message = json.loads(line)
        if not message["ok"]:
            raise AssertionError(message["error"])
        return message["value"]

    def _send(self, op: str, **fields: Any) -> Any:
        assert self._process.stdin is not None
        self._process.stdin.write(json.dumps({"op": op, **fields}) + "\n")
        self._process.stdin.flush()
        return self._answer(op)

    def goto(self, url: str) -> None:
        self._send("goto", url=url, timeout=WAIT_S * 1000)

    def click(self, selector: str) -> None:
        self._send("click", selector=selector)

    def wait_for(self, selector: str, *, gone: bool = False) -> None:
        self._send("wait", selector=selector, gone=gone, timeout=WAIT_S * 1000)

    def evaluate(self, expression: str) -> Any:
        return self._send("evaluate", expression=expression)

    def errors(self) -> list[str] | None:
        return list(self._send("errors"))

    def close(self) -> None:
        try:
            if self._process.poll() is None:
                self._send("close")
        finally:
            self._stop()

    def _stop(self) -> None:
        if self._process.stdin is not None:
            self._process.stdin.close()
        try:
            self._process.wait(WAIT_S)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._reader.join(WAIT_S)
        if self._process.stdout is not None:
            self._process.stdout.close()


if __name__ == "__main__":  # make test: install it before the tests run
    try:
        print(f"puppeteer-core {PUPPETEER_VERSION}: {install()}")
    except RuntimeError as exc:
        print(f"puppeteer-core: {exc}", file=sys.stderr)
        sys.exit(1)
