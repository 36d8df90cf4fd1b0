"""The browser a participant used, by its own name, read from the User-Agent header.

User agents borrow each other's tokens: Chrome's names Safari, Edge's, Opera's and Samsung
Internet's name Chrome, and every WebKit browser names Safari. So the rules are tried in order,
the most specific first (:data:`RULES`), and "Safari" is Apple's Safari only on Apple's
platforms. WebKitGTK (GNOME Web, formerly Epiphany, and other GTK applications; WPE on Linux
devices) sends Safari's tokens too, "Version/18.0 Safari/605.1.15", but on X11 or Linux: that
is not Apple's Safari, and its "Version/" is the Safari version it imitates, not its own, so
it is recorded without one (https://bugs.webkit.org/show_bug.cgi?id=282403). GNOME Web appends
``Epiphany/<version>``, which older releases filled with WebKit's frozen 605.1.15 rather than
their own.

What a header cannot tell is left as it is: Firefox ESR sends the same header as the Firefox
release of its major version ("Firefox 128" is either), Debian's and Fedora's Chromium send
Chrome's (only Ubuntu's old builds named Chromium), Brave sends Chrome's, and Tor Browser
Firefox ESR's.

>>> browser_of("Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/605.1.15 (KHTML, like Gecko) "
...            "Version/18.0 Safari/605.1.15 Epiphany/605.1.15")
('GNOME Web', '')
>>> browser_of("Mozilla/5.0 (Macintosh; Intel Mac OS X 10_15_7) AppleWebKit/605.1.15 (KHTML, "
...            "like Gecko) Version/18.1 Safari/605.1.15")
('Safari', '18')
"""

from __future__ import annotations

import re
from typing import Final

#: (family, pattern): the first pattern found names the browser; its group, if any, holds the
#: major version. Order matters (see the module's docstring): the Chromium-based browsers name
#: Chrome, so they come before it, and every rule before the two WebKit ones takes a browser
#: that names Safari too.
RULES: Final[tuple[tuple[str, str], ...]] = (
    ("Edge", r"\bEdg(?:e|A|iOS)?/(\d+)"),
    ("Opera", r"\b(?:OPR|OPT)/(\d+)"),
    ("Samsung Internet", r"\bSamsungBrowser/(\d+)"),
    ("Vivaldi", r"\bVivaldi/(\d+)"),
    ("Yandex Browser", r"\bYaBrowser/(\d+)"),
    ("UC Browser", r"\bUCBrowser/(\d+)"),
    ("SeaMonkey", r"\bSeaMonkey/(\d+)"),
    ("Firefox", r"\b(?:Firefox|FxiOS)/(\d+)"),
    # GNOME Web's own version, not WebKit's frozen one that older releases put there
    ("GNOME Web", r"\bEpiphany/(?!605\.1\.15\b)(\d+)"),
    ("GNOME Web", r"\bEpiphany/"),
    ("Chromium", r"\bChromium/(\d+)"),
    ("Headless Chrome", r"\bHeadlessChrome/(\d+)"),
    ("Android WebView", r"; wv\).*\bChrome/(\d+)"),
    ("Chrome", r"\b(?:Chrome|CriOS)/(\d+)"),
    # Apple's platforms only: a WebKit browser naming Safari elsewhere is not Safari
    (
        "Safari",
        r"\((?:Macintosh|iPhone|iPad|iPod)\b.*\bAppleWebKit/.*"
        r"\bVersion/(\d+)[.\d]* (?:Mobile/\S+ )?Safari/",
    ),
    # X11, Wayland or a bare Linux or BSD platform, not Android: WebKitGTK or WPE
    ("WebKitGTK", r"\((?![^)]*Android)[^)]*(?:Linux|BSD)[^)]*\) AppleWebKit/.*\bSafari/"),
    ("Internet Explorer", r"\bMSIE (\d+)|\bTrident/.*\brv:(\d+)"),
)
_COMPILED: Final = tuple((family, re.compile(pattern)) for family, pattern in RULES)


def browser_of(user_agent: str) -> tuple[str, str]:
    """(family, major version) read from a User-Agent header; the version is "" where the
    header does not tell it, and ("other", "") names a browser not known here.

    Parsed on the server from the header every request carries, not fingerprinted in the page.
    """
    for family, pattern in _COMPILED:
        found = pattern.search(user_agent)
        if found:
            version = next((g for g in found.groups() if g), "")
            return family, version
    return "other", ""
