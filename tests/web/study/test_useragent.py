"""The browser named from real User-Agent headers: the one each browser sends, as published by
its makers or recorded in the wild; "Safari" only for Apple's, WebKitGTK and GNOME Web by
their own names."""

import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.web.study.useragent import RULES, browser_of

AGENTS = [
    # GNOME Web (Epiphany) on WebKitGTK: older releases put WebKit's frozen version in place
    # of their own
    (
        "Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/605.1.15 (KHTML, like Gecko) "
        "Version/18.0 Safari/605.1.15 Epiphany/605.1.15",
        ("GNOME Web", ""),
    ),
    (
        "Mozilla/5.0 (X11; Ubuntu; Linux x86_64) AppleWebKit/605.1.15 (KHTML, like Gecko) "
        "Version/16.0 Safari/605.1.15 Epiphany/605.1.15",
        ("GNOME Web", ""),
    ),
    (
        "Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/605.1.15 (KHTML, like Gecko) "
        "Version/17.0 Safari/605.1.15 Epiphany/46.0",
        ("GNOME Web", "46"),
    ),
    # WebKitGTK's own header (no application name): Safari's tokens on X11, not Apple's Safari
    (
        "Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/605.1.15 (KHTML, like Gecko) "
        "Version/18.0 Safari/605.1.15",
        ("WebKitGTK", ""),
    ),
    (
        "Mozilla/5.0 (X11; FreeBSD amd64) AppleWebKit/605.1.15 (KHTML, like Gecko) "
        "Version/17.0 Safari/605.1.15",
        ("WebKitGTK", ""),
    ),
    (
        "Mozilla/5.0 (Macintosh; Intel Mac OS X 10_15_7) AppleWebKit/605.1.15 (KHTML, like "
        "Gecko) Version/18.1 Safari/605.1.15",
        ("Safari", "18"),
    ),
    (
        "Mozilla/5.0 (iPhone; CPU iPhone OS 17_5 like Mac OS X) AppleWebKit/605.1.15 (KHTML, "
        "like Gecko) Version/17.5 Mobile/15E148 Safari/604.1",
        ("Safari", "17"),
    ),
    (
        "Mozilla/5.0 (iPad; CPU OS 17_7 like Mac OS X) AppleWebKit/605.1.15 (KHTML, like Gecko) "
        "Version/17.7 Mobile/15E148 Safari/604.1",
        ("Safari", "17"),
    ),
    # Firefox ESR 128 sends Firefox 128's header: the release it follows
    (
        "Mozilla/5.0 (X11; Linux x86_64; rv:128.0) Gecko/20100101 Firefox/128.0",
        ("Firefox", "128"),
    ),
    (
        "Mozilla/5.0 (Windows NT 10.0; Win64; x64; rv:133.0) Gecko/20100101 Firefox/133.0",
        ("Firefox", "133"),
    ),
    ("Mozilla/5.0 (Android 14; Mobile; rv:133.0) Gecko/133.0 Firefox/133.0", ("Firefox", "133")),
    (
        "Mozilla/5.0 (iPhone; CPU iPhone OS 17_7 like Mac OS X) AppleWebKit/605.1.15 (KHTML, "
        "like Gecko) FxiOS/133.0 Mobile/15E148 Safari/605.1.15",
        ("Firefox", "133"),
    ),
    (
        "Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/537.36 (KHTML, like Gecko) "
        "Ubuntu Chromium/79.0.3945.79 Chrome/79.0.3945.79 Safari/537.36",
        ("Chromium", "79"),
    ),
    (
        "Mozilla/5.0 (Windows NT 10.0; Win64; x64) AppleWebKit/537.36 (KHTML, like Gecko) "
        "Chrome/131.0.0.0 Safari/537.36",
        ("Chrome", "131"),
    ),
    (
        "Mozilla/5.0 (Linux; Android 10; K) AppleWebKit/537.36 (KHTML, like Gecko) "
        "Chrome/131.0.0.0 Mobile Safari/537.36",
        ("Chrome", "131"),
    ),
    (
        "Mozilla/5.0 (iPhone; CPU iPhone OS 17_7 like Mac OS X) AppleWebKit/605.1.15 (KHTML, "
        "like Gecko) CriOS/131.0.6778.73 Mobile/15E148 Safari/604.1",
        ("Chrome", "131"),
    ),
    (
        "Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/537.36 (KHTML, like Gecko) "
        "HeadlessChrome/131.0.6778.33 Safari/537.36",
        ("Headless Chrome", "131"),
    ),
    (
        "Mozilla/5.0 (Linux; Android 14; Pixel 8 Build/AP2A.240805.005; wv) AppleWebKit/537.36 "
        "(KHTML, like Gecko) Version/4.0 Chrome/113.0.5672.136 Mobile Safari/537.36",
        ("Android WebView", "113"),
    ),
    (
        "Mozilla/5.0 (Windows NT 10.0; Win64; x64) AppleWebKit/537.36 (KHTML, like Gecko) "
        "Chrome/126.0.0.0 Safari/537.36 Edg/126.0.2592.87",
        ("Edge", "126"),
    ),
    (
        "Mozilla/5.0 (Linux; Android 10; K) AppleWebKit/537.36 (KHTML, like Gecko) "
        "Chrome/131.0.0.0 Mobile Safari/537.36 EdgA/131.0.0.0",
        ("Edge", "131"),
    ),
    (
        "Mozilla/5.0 (Windows NT 10.0; Win64; x64) AppleWebKit/537.36 (KHTML, like Gecko) "
        "Chrome/130.0.0.0 Safari/537.36 OPR/115.0.0.0",
        ("Opera", "115"),
    ),
    (
        "Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/537.36 (KHTML, like Gecko) "
        "Chrome/130.0.0.0 Safari/537.36 Vivaldi/7.0.3495.18",
        ("Vivaldi", "7"),
    ),
    (
        "Mozilla/5.0 (Linux; Android 14; SM-S918B) AppleWebKit/537.36 (KHTML, like Gecko) "
        "SamsungBrowser/25.0 Chrome/121.0.0.0 Mobile Safari/537.36",
        ("Samsung Internet", "25"),
    ),
    (
        "Mozilla/5.0 (Windows NT 10.0; Win64; x64) AppleWebKit/537.36 (KHTML, like Gecko) "
        "Chrome/128.0.0.0 YaBrowser/24.10.0.0 Safari/537.36",
        ("Yandex Browser", "24"),
    ),
    (
        "Mozilla/5.0 (Windows NT 10.0; WOW64; Trident/7.0; rv:11.0) like Gecko",
        ("Internet Explorer", "11"),
    ),
    # Android's old stock browser names Safari on Linux too: not WebKitGTK
    (
        "Mozilla/5.0 (Linux; U; Android 4.0.3; ko-kr; LG-L160L Build/IML74K) AppleWebKit/534.30 "
        "(KHTML, like Gecko) Version/4.0 Mobile Safari/534.30",
        ("other", ""),
    ),
    ("curl/8.5.0", ("other", "")),
    ("", ("other", "")),
]


@pytest.mark.parametrize(("agent", "expected"), AGENTS)
def test_the_browser_is_named_as_it_is(agent, expected):
    assert browser_of(agent) == expected


#: Pieces of real headers, so that the generated ones reach past the first rule's miss.
TOKENS = st.sampled_from(
    [
        "Mozilla/5.0 ",
        "(X11; Linux x86_64) ",
        "(Macintosh; Intel Mac OS X 10_15_7) ",
        "(Linux; Android 14; wv) ",
        "AppleWebKit/605.1.15 ",
        "(KHTML, like Gecko) ",
        "Version/18.0 ",
        "Safari/605.1.15 ",
        "Chrome/131.0.0.0 ",
        "Epiphany/",
        "Firefox/",
        "Edg/",
        "Trident/7.0; rv:11.0) ",
        "MSIE ",
        "605.1.15",
        "99999999999999999999",
    ]
)


@settings(max_examples=300, deadline=None)
@given(st.lists(TOKENS | st.text(max_size=12), max_size=12).map("".join))
def test_any_header_names_a_known_family_and_a_number_or_nothing(agent):
    family, version = browser_of(agent)
    assert family in {name for name, _ in RULES} | {"other"}
    assert re.fullmatch(r"\d*", version)
    # "Safari" is Apple's alone
    if family == "Safari":
        assert re.search(r"Macintosh|iPhone|iPad|iPod", agent)
