"""The media log's and the environment's checks, and the browser read from User-Agent."""

import pytest

from app.web.study.medialog import MediaLogError, browser_of, environment_fields, media_fields


@pytest.mark.parametrize(
    ("agent", "expected"),
    [
        (
            "Mozilla/5.0 (Windows NT 10.0; Win64; x64) AppleWebKit/537.36 (KHTML, like Gecko) "
            "Chrome/126.0.0.0 Safari/537.36 Edg/126.0.2592.87",
            ("Edge", "126"),
        ),
        (
            "Mozilla/5.0 (X11; Linux x86_64; rv:128.0) Gecko/20100101 Firefox/128.0",
            ("Firefox", "128"),
        ),
        (
            "Mozilla/5.0 (iPhone; CPU iPhone OS 17_5 like Mac OS X) AppleWebKit/605.1.15 (KHTML, "
            "like Gecko) Version/17.5 Mobile/15E148 Safari/604.1",
            ("Safari", "17"),
        ),
        (
            "Mozilla/5.0 (Linux; Android 14; SM-S918B) AppleWebKit/537.36 (KHTML, like Gecko) "
            "SamsungBrowser/25.0 Chrome/121.0.0.0 Mobile Safari/537.36",
            ("Samsung Internet", "25"),
        ),
        ("curl/8.5.0", ("other", "")),
    ],
)
def test_browser_family_and_major_version(agent, expected):
    assert browser_of(agent) == expected


def test_media_log_splits_columns_from_the_rest():
    columns, log = media_fields({"watched_ms": 10.0, "stall_durations": list(range(80))})
    assert columns["watched_ms"] == 10 and columns["played_to_end"] is None
    assert len(log["stall_durations"]) == 50
    assert media_fields(None) == ({}, {})
    with pytest.raises(MediaLogError, match="watched_ms"):
        media_fields({"watched_ms": 10**12})


def test_viewing_check_passes_only_from_the_minimum_face_size():
    report = {"face_px": 159}
    assert environment_fields(report, "", min_face_px=160)["viewing_ok"] is False
    assert environment_fields({"face_px": 160}, "", min_face_px=160)["viewing_ok"] is True
    assert environment_fields({}, "", min_face_px=0)["viewing_ok"] is True
    with pytest.raises(MediaLogError, match="dpr"):
        environment_fields({"dpr": 0}, "", min_face_px=0)
