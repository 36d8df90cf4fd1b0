"""An engine that is not installed skips its browser test on a developer's machine and fails it
in CI, so no engine silently drops out there (tests/support/engines.py, puppeteer.py)."""

from __future__ import annotations

import pytest

from tests.support import engines, puppeteer


@pytest.mark.parametrize(
    "ci, outcome", [("true", pytest.fail.Exception), ("", pytest.skip.Exception)]
)
@pytest.mark.parametrize("engine", ["firefox", "webkit"])
def test_a_missing_engine_fails_in_ci_and_skips_elsewhere(monkeypatch, engine, ci, outcome):
    monkeypatch.setenv("CI", ci)
    monkeypatch.setattr(engines, "WEBKIT_DRIVER", "no-such-WebKitWebDriver")
    monkeypatch.setattr(puppeteer, "FIREFOXES", ("no-such-firefox",))
    with pytest.raises(outcome, match="make test. installs the browsers"):
        with engines.open_page(engine, None, {"width": 800, "height": 600}):
            pass


def test_an_unknown_engine_is_named():
    with pytest.raises(ValueError, match="unknown browser engine: lynx"):
        with engines.open_page("lynx", None, {"width": 800, "height": 600}):
            pass


def test_a_firefox_without_puppeteer_core_fails_in_ci(monkeypatch, tmp_path):
    monkeypatch.setenv("CI", "true")
    monkeypatch.setattr(puppeteer, "PACKAGE", tmp_path / "none")
    # Firefox and node are there, npm (to install puppeteer-core with) is not
    monkeypatch.setattr(
        puppeteer.shutil, "which", lambda name: None if name == "npm" else f"/usr/bin/{name}"
    )
    with pytest.raises(pytest.fail.Exception, match="puppeteer-core unavailable"):
        puppeteer.FirefoxPage({"width": 800, "height": 600})
