"""Live Link Face's timecodes, ``HH:MM:SS:FF.sss``, to seconds.

``FF`` is a frame of the app's frame rate (60 by default, 30 on request). What the digits
after the point hold differs between writers: a sub-frame fraction in the app's takes (so a
frame stored a hair early reads ``44.999``, the next ``46.000``), a running counter
(``01.001``, ``02.002``) in files written by speech-driven tools in this layout (NeuroSync),
nothing at all in others (OpenFaceFX's ``hello.arkit.csv``). :func:`frame_times` reads the
times both ways, with and without the fraction, and keeps the one whose steps are whole
frames. :mod:`app.stimuli.capture.arkit` reads the rest of the file.
"""

from __future__ import annotations

import re

import numpy as np

#: A timecode: hours, minutes, seconds, frame and the optional digits after the point.
TIMECODE = re.compile(r"^(\d+):(\d{1,2}):(\d{1,2}):(\d{1,3})(?:\.(\d+))?$")


def parse_timecode(text: str, app_fps: float) -> float:
    """``HH:MM:SS:FF.sss`` -> seconds of frame ``FF`` of ``app_fps``.

    The digits after the point are not used: exports of different app versions fill them
    differently (``01.001``, ``02.002`` ... in some, sub-frame fractions in others), and a frame
    is placed by its number alone.

    >>> parse_timecode("00:00:01:30.507", 60.0)
    1.5
    """
    m = TIMECODE.match(text.strip())
    if not m:
        raise ValueError(f"expected a timecode HH:MM:SS:FF(.sss), got {text[:40]!r}")
    h, mi, s, ff = (int(g) for g in m.groups()[:4])
    return h * 3600 + mi * 60 + s + ff / app_fps


def _irregular_steps(times: np.ndarray, app_fps: float) -> tuple[int, int]:
    """How many steps between stamps are not a whole number of frames (or are 0), and how
    many skip a frame (two or more frames long)."""
    steps = np.diff(times) * app_fps
    positive = steps[steps > 1e-9]
    if not len(positive):
        return len(steps), 0
    unit = float(np.median(positive))
    ratio = steps / unit
    irregular = (np.abs(ratio - np.round(ratio)) > 0.25) | (np.round(ratio) < 1)
    return int(irregular.sum()), int(np.sum(~irregular & (np.round(ratio) >= 2)))


def _subframe(text: str) -> float:
    """The digits after a timecode's point as a fraction (0 without them)."""
    m = TIMECODE.match(text.strip())
    return float("0." + m.group(5)) if m and m.group(5) else 0.0


def frame_times(stamps: list[str], app_fps: float) -> tuple[np.ndarray, bool]:
    """Seconds of each timecode, and whether the digits after the point were used.

    Both readings are tried: frame numbers alone (:func:`parse_timecode`) and frame numbers
    plus the digits after the point as a fraction of a frame. The reading with fewer steps
    that are not whole frames wins, then the one that skips fewer frames (a frame stored a
    hair early, ``44.999`` before ``46.000``, is one frame from it, not two); a tie keeps the
    frame numbers alone (a running counter, ``01.001``, ``02.002``, is no fraction).

    >>> stamps = ["00:00:00:43.000", "00:00:00:44.000", "00:00:00:44.999", "00:00:00:46.000"]
    >>> times, fraction = frame_times(stamps, 60.0)
    >>> (np.diff(times) * 60).round(3).tolist(), fraction
    ([1.0, 0.999, 1.001], True)
    >>> times, fraction = frame_times(["00:00:00:42.999", "00:00:00:43.999", "00:00:00:44.999",
    ...                                "00:00:00:46.000"], 60.0)
    >>> (np.diff(times) * 60).round(3).tolist(), fraction
    ([1.0, 1.0, 1.001], True)
    """
    whole = np.array([parse_timecode(s, app_fps) for s in stamps])
    frac = np.array([_subframe(s) for s in stamps])
    fine = whole + frac / app_fps
    if not frac.any() or len(whole) < 2:
        return whole, False
    if _irregular_steps(fine, app_fps) < _irregular_steps(whole, app_fps):
        return fine, True
    return whole, False


def timecode_problem(text: str) -> str | None:
    """Why ``text`` is not a timecode, or ``None`` when it is one."""
    return None if TIMECODE.match(text) else f"expected HH:MM:SS:FF(.sss), got {text[:40]!r}"
