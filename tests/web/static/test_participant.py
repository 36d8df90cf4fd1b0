"""The participant pages' shared script (``static/participant.js``), run in node: its reading of
the server's answers to a vote (stored, refused for good because the study closed, refused so
the answer is given back, or sent again: only after a network error or a 5xx, honouring
Retry-After), its filling in of translated strings, and each page's own script running on what
it lends them."""

import json
import shutil
import subprocess
from pathlib import Path

import pytest

STATIC = Path(__file__).resolve().parents[3] / "app" / "web" / "static"
SCRIPT = STATIC / "participant.js"
#: The participant pages' own scripts, each loaded after participant.js (the templates).
PAGE_SCRIPTS = ("pair.js", "rating.js", "instructions.js", "audio_check.js", "done.js")
# Just enough of a browser for the script to load on a page without a player.
PRELUDE = """
global.window = { localStorage: null, addEventListener: function () {} };
global.document = { querySelectorAll: function () { return []; },
                    querySelector: function () { return null; },
                    getElementById: function () { return null; },
                    addEventListener: function () {} };
require(process.argv[1]);
"""
HARNESS = (
    PRELUDE
    + """
var votes = window.facepairVotes;
var cases = JSON.parse(process.argv[2]);
console.log(JSON.stringify(cases.map(function (c) {
  return c[0] >= 100 ? votes.action(c[0], c[1]) : votes.wait(c[0], c[1]);
})));
"""
)


def _run(cases: object, harness: str = HARNESS) -> list:
    node = shutil.which("node") or shutil.which("nodejs")
    if node is None:
        pytest.skip("node is not installed")
    result = subprocess.run(
        [node, "-e", harness, str(SCRIPT), json.dumps(cases)],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    )
    return json.loads(result.stdout)


def test_only_server_errors_are_sent_again():
    cases = [
        [201, {}],
        [200, {"status": "duplicate"}],
        [409, {"error": "this study is closed", "closed": True}],
        [409, {"error": "idempotency_key: already used for another trial"}],
        [400, {"error": "plays: required"}],
        [404, {}],
        [413, {}],
        [422, {}],
        [429, {}],
        [500, {}],
        [502, {}],
        [503, {"error": "the database is unavailable"}],
    ]
    assert _run(cases) == [
        "saved",
        "saved",
        "closed",
        "refused",
        "refused",
        "refused",
        "refused",
        "refused",
        "refused",
        "retry",
        "retry",
        "retry",
    ]


def test_retry_waits_for_retry_after_else_backs_off():
    cases = [[1, "5"], [3, "5"], [1, "0"], [1, "600"], [1, None], [2, None], [5, None], [9, "soon"]]
    assert _run(cases) == [5000, 5000, 1000, 30000, 1000, 2000, 16000, 30000]


FORMAT = (
    PRELUDE
    + """
var format = window.facepairText.format;
var cases = JSON.parse(process.argv[2]);
console.log(JSON.stringify(cases.map(function (c) { return format(c[0], c[1]); })));
"""
)


def test_translated_strings_are_filled_in_as_python_would():
    """The script fills a catalogue's ``%(name)s`` placeholders (in the language's order) and
    reads ``%%`` as one percent sign, as Python's ``%`` formatting does on the server."""
    cases = [
        ["Pair %(number)s of %(total)s", {"number": 2, "total": 9}],
        ["ペア %(number)s / %(total)s", {"total": 9, "number": 2}],
        ["Loading… %(percent)s%%", {"percent": 40}],
        ["%(num)d plays left", {"num": 3}],
    ]
    assert _run(cases, FORMAT) == [text % values for text, values in cases]


PAGE = (
    PRELUDE
    + """
require(JSON.parse(process.argv[2]));
console.log(JSON.stringify(Object.keys(window.facepairText)));
"""
)


@pytest.mark.parametrize("name", PAGE_SCRIPTS)
def test_each_page_script_runs_on_what_the_shared_script_lends(name):
    """A page's own script takes the helpers and the words from ``window.facepairVotes`` and
    ``window.facepairText``: loaded after the shared script on a page without its elements,
    it runs through without an error."""
    assert _run(str(STATIC / name), PAGE) == ["format", "strings"]
