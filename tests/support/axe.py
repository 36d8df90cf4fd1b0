"""axe-core for the browser tests: the accessibility rules run inside each page type.

axe-core comes from the npm registry at test set-up time (``make test`` runs ``python -m
tests.support.axe`` first, which installs the pinned version into ``.cache/axe-core``); nothing
of it is committed. :func:`axe_script` finds it, installs it when npm is there, and skips the
test with the reason when neither works, except under CI (``CI`` set), where a missing axe-core
fails the test: the accessibility checks must run there.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

AXE_VERSION = "4.14.1"
ROOT = Path(__file__).resolve().parents[2]
PREFIX = Path(os.environ.get("FACEPAIR_AXE_DIR", ROOT / ".cache" / "axe-core"))
SCRIPT = PREFIX / "node_modules" / "axe-core" / "axe.min.js"
#: Every rule of these standards runs (WCAG 2.2 A and AA and axe's best practices); any
#: violation, whatever its impact, fails the test.
TAGS = ["wcag2a", "wcag2aa", "wcag21a", "wcag21aa", "wcag22aa", "best-practice"]


def install() -> Path:
    """Install the pinned axe-core into :data:`PREFIX` unless it is there; its script's path.
    Raises ``RuntimeError`` with the reason when that cannot be done."""
    if SCRIPT.exists() and _installed_version() == AXE_VERSION:
        return SCRIPT
    npm = shutil.which("npm")
    if npm is None:
        raise RuntimeError("npm is not installed (Debian: apt-get install npm)")
    PREFIX.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(
        [
            npm,
            "install",
            "--prefix",
            str(PREFIX),
            "--no-save",
            "--no-audit",
            "--no-fund",
            f"axe-core@{AXE_VERSION}",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    if done.returncode != 0 or not SCRIPT.exists():
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise RuntimeError(f"npm install axe-core@{AXE_VERSION} failed: {last}")
    return SCRIPT


def _installed_version() -> str | None:
    import json

    package = SCRIPT.parent / "package.json"
    try:
        return str(json.loads(package.read_text(encoding="utf-8"))["version"])
    except (OSError, ValueError, KeyError):
        return None


def axe_script() -> Path:
    """The path of ``axe.min.js``, for a test; skips (fails under CI) when it cannot be had."""
    try:
        return install()
    except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
        if os.environ.get("CI"):
            pytest.fail(f"axe-core is needed for the accessibility checks: {exc}")
        pytest.skip(f"axe-core unavailable: {exc}")


def violations(page, script: Path) -> list[str]:
    """Run axe-core on ``page`` (its context made with ``bypass_csp=True``, so the script can
    be injected past the pages' Content-Security-Policy); one line per violation and node."""
    page.add_script_tag(path=str(script))
    result = page.evaluate(
        "tags => axe.run(document, {runOnly: {type: 'tag', values: tags}, resultTypes: "
        "['violations']})",
        TAGS,
    )
    return [
        f"{page.url}: {v['id']} ({v['impact']}): {v['help']} at {node['target']}"
        for v in result["violations"]
        for node in v["nodes"]
    ]


if __name__ == "__main__":  # make test: install it before the tests run
    try:
        print(f"axe-core {AXE_VERSION}: {install()}")
    except RuntimeError as exc:
        print(f"axe-core: {exc}", file=sys.stderr)
        sys.exit(1)
