"""What a participant actually saw: the media log sent with each vote, and the device and
viewing conditions recorded once before the first trial.

Crowdsourced video-quality practice (ITU-T P.910's crowdsourcing annex, AVrate Voyager) keeps,
per rating, whether the clip played to its end, how long it stalled and whether the window lost
focus, and per participant the screen, the browser and a viewing check; HEMVIP logs plays per
stimulus. The browser reports; this module checks every field's type and range and returns one
line naming the first bad field, so a hostile or broken client never causes a 5xx.

>>> media_fields({"watched_ms": 4000, "played_to_end": True, "stalls": 1, "stall_ms": 800,
...               "focus_lost": 0, "pauses": 1, "seeks": 0, "width": 640, "height": 320,
...               "stall_durations": [800]})[0]["stall_ms"]
800
>>> browser_of("Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/537.36 (KHTML, like Gecko) "
...            "Chrome/126.0.6478.126 Safari/537.36")
('Chrome', '126')
"""

from __future__ import annotations

from typing import Any, Final

from app.web.study.useragent import browser_of

#: Summary fields stored as vote columns (and exported), with their upper bounds.
MEDIA_COUNTS: Final = {
    "watched_ms": 86_400_000,
    "stalls": 100_000,
    "stall_ms": 86_400_000,
    "focus_lost": 100_000,
}
#: Further fields kept in the vote's JSON media log.
MEDIA_EXTRA: Final = {"pauses": 100_000, "seeks": 100_000, "width": 100_000, "height": 100_000}
MAX_STALLS_KEPT: Final = 50

#: Environment fields (whole numbers with their upper bounds), reported once per participant.
ENVIRONMENT_COUNTS: Final = {
    "screen_w": 100_000,
    "screen_h": 100_000,
    "viewport_w": 100_000,
    "viewport_h": 100_000,
    "face_px": 100_000,
}


class MediaLogError(ValueError):
    """A field of the media log or the environment is not what it should be."""


def _whole(payload: dict[str, Any], name: str, highest: int) -> int | None:
    value = payload.get(name)
    if value is None:
        return None
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= highest:
        raise MediaLogError(f"{name}: expected a whole number from 0 to {highest}")
    return value


def media_fields(media: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """(vote columns, JSON log) from the ``media`` object of a vote request.

    Columns: ``watched_ms``, ``played_to_end``, ``stalls``, ``stall_ms``, ``focus_lost``;
    the log keeps ``pauses``, ``seeks``, the video's displayed ``width`` and ``height`` (CSS
    pixels) and the first :data:`MAX_STALLS_KEPT` ``stall_durations`` (ms). Absent fields stay
    None; an absent log gives empty results. Raises :class:`MediaLogError`.
    """
    if media is None:
        return {}, {}
    if not isinstance(media, dict):
        raise MediaLogError("media: expected an object")
    columns: dict[str, Any] = {name: _whole(media, name, top) for name, top in MEDIA_COUNTS.items()}
    ended = media.get("played_to_end")
    if ended is not None and not isinstance(ended, bool):
        raise MediaLogError("played_to_end: expected true or false")
    columns["played_to_end"] = ended
    log = {name: _whole(media, name, top) for name, top in MEDIA_EXTRA.items()}
    durations = media.get("stall_durations", [])
    if not isinstance(durations, list):
        raise MediaLogError("stall_durations: expected a list of milliseconds")
    log["stall_durations"] = [
        _whole({"stall_durations": d}, "stall_durations", MEDIA_COUNTS["stall_ms"])
        for d in durations[:MAX_STALLS_KEPT]
    ]
    return columns, {k: v for k, v in log.items() if v is not None}


def environment_fields(payload: Any, user_agent: str, *, min_face_px: int) -> dict[str, Any]:
    """The participant's environment from the page's report and the User-Agent header.

    The page reports screen and viewport size (CSS pixels), ``dpr`` (device pixel ratio),
    ``touch`` and ``face_px``: how wide one face of the clip is shown. The viewing check
    passes when ``face_px >= min_face_px`` (always with ``min_face_px = 0``); the result is
    stored as ``viewing_ok``. Raises :class:`MediaLogError`.
    """
    if not isinstance(payload, dict):
        raise MediaLogError("body: expected a JSON object")
    out: dict[str, Any] = {
        name: _whole(payload, name, top) for name, top in ENVIRONMENT_COUNTS.items()
    }
    dpr = payload.get("dpr")
    if dpr is not None and (
        isinstance(dpr, bool) or not isinstance(dpr, int | float) or not 0 < dpr <= 16
    ):
        raise MediaLogError("dpr: expected a number above 0 and at most 16")
    touch = payload.get("touch")
    if touch is not None and not isinstance(touch, bool):
        raise MediaLogError("touch: expected true or false")
    out["dpr"], out["touch"] = dpr, touch
    out["browser"], out["browser_version"] = browser_of(user_agent)
    out["viewing_ok"] = min_face_px == 0 or (out["face_px"] or 0) >= min_face_px
    return out
