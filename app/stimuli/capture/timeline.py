"""From irregular tracker samples to a uniform FAP track: gaps filled or refused, resampled.

Trackers write one row per video frame with a time stamp; frames go missing (a dropped or
duplicated frame at 29.97 fps, a face the tracker lost). :func:`to_track` places every valid
sample at its time, fills short gaps by linear interpolation and refuses long ones with one
line naming the frames, then resamples to the study's frame rate
(:meth:`app.stimuli.track.MotionTrack.resample`, which low-passes before downsampling).

Example
-------
>>> t = np.array([0.0, 0.1, 0.2, 0.4])            # a frame at 0.3 s is missing
>>> track, report = to_track(t, {48: np.array([0.0, 1.0, 2.0, 4.0])}, np.ones(4, bool),
...                          fps=10.0, source="x")
>>> track[48].round(6).tolist(), report["filled_frames"]
([0.0, 1.0, 2.0, 3.0, 4.0], 1)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.track import MotionTrack

#: Longest gap filled by interpolation, seconds; longer gaps are an error.
MAX_GAP_S = 0.5
#: Capture rates accepted, frames a second, and the longest take, seconds (a bound on memory).
RATE_RANGE = (1.0, 2000.0)
MAX_DURATION_S = 4 * 3600.0


def to_track(
    times: np.ndarray,
    columns: Mapping[int, np.ndarray],
    valid: np.ndarray,
    *,
    fps: float,
    source: str,
    path: str | None = None,
    max_gap_s: float = MAX_GAP_S,
    rows: np.ndarray | None = None,
    name: str = "",
) -> tuple[MotionTrack, dict[str, Any]]:
    """A track at ``fps`` from samples at ``times`` (seconds) where ``valid`` is true.

    The capture's own rate is the median spacing of the valid samples; the samples are put on
    that grid (duplicated times keep the last sample), gaps up to ``max_gap_s`` are filled
    linearly, and the grid is resampled to ``fps``. ``rows`` (the file's line numbers of the
    samples) name the rows of a gap too long to fill. Returns the track and a report:
    ``capture_fps``, ``samples``, ``invalid_samples``, ``filled_frames``, ``gaps`` (start and
    end seconds of each filled gap), ``duplicates``.
    """
    columns = dict(sorted(columns.items()))
    t = np.asarray(times, dtype=np.float64)
    ok = np.asarray(valid, dtype=bool) & np.isfinite(t)
    for col in columns.values():
        ok &= np.isfinite(np.asarray(col, dtype=np.float64))
    if ok.sum() < 2:
        raise InputError(f"fewer than 2 usable frames ({int(ok.sum())} of {len(t)})", path=path)
    tv = t[ok]
    steps = np.diff(tv)
    if np.any(steps < 0):
        k = int(np.flatnonzero(steps < 0)[0]) + 1
        where = f"row {int(rows[ok][k])}" if rows is not None else f"sample {k}"
        raise InputError(
            f"{where}: time goes backwards ({tv[k - 1]:.3f} s then {tv[k]:.3f} s)", path=path
        )
    positive = steps[steps > 0]
    if len(positive) == 0:
        raise InputError("all usable frames have the same time stamp", path=path)
    capture_fps = capture_rate(tv)
    if not RATE_RANGE[0] <= capture_fps <= RATE_RANGE[1]:
        raise InputError(
            f"the time stamps give {capture_fps:.3g} frames a second; expected "
            f"{RATE_RANGE[0]:g}-{RATE_RANGE[1]:g} (are they in seconds?)",
            path=path,
        )
    if tv[-1] - tv[0] > MAX_DURATION_S:
        raise InputError(
            f"the take lasts {tv[-1] - tv[0]:.3g} s, more than {MAX_DURATION_S / 3600:g} hours",
            path=path,
        )
    grid_index = np.round((tv - tv[0]) * capture_fps).astype(np.int64)
    n_grid = int(grid_index[-1]) + 1
    duplicates = int(len(grid_index) - len(np.unique(grid_index)))
    filled = np.ones(n_grid, dtype=bool)
    filled[grid_index] = False
    gaps = _runs(filled)
    too_long = [(a, b) for a, b in gaps if (b - a) / capture_fps > max_gap_s]
    if too_long:
        a, b = too_long[0]
        rows_ok = rows[ok] if rows is not None else None
        before = int(rows_ok[np.searchsorted(grid_index, a) - 1]) if rows_ok is not None else a
        after = int(rows_ok[np.searchsorted(grid_index, b)]) if rows_ok is not None else b
        raise InputError(
            f"no usable frame for {(b - a) / capture_fps:.2f} s between rows {before} and "
            f"{after} ({tv[0] + a / capture_fps:.2f}-{tv[0] + b / capture_fps:.2f} s), more "
            f"than the {max_gap_s:g} s that are filled by interpolation",
            path=path,
        )
    grid_t = np.arange(n_grid)
    values = (
        np.column_stack(
            [
                np.interp(grid_t, grid_index, np.asarray(col, dtype=np.float64)[ok])
                for col in columns.values()
            ]
        )
        if columns
        else np.zeros((n_grid, 0))
    )
    raw = MotionTrack(capture_fps, values, tuple(columns), name=name, source=source)
    track = raw.resample(fps) if abs(capture_fps - fps) > 1e-6 else raw.replace(fps=fps)
    report = {
        "capture_fps": round(capture_fps, 4),
        "samples": int(len(t)),
        "invalid_samples": int(len(t) - ok.sum()),
        "filled_frames": int(filled.sum()),
        "gaps": [
            [round(tv[0] + a / capture_fps, 3), round(tv[0] + b / capture_fps, 3)] for a, b in gaps
        ],
        "duplicates": duplicates,
        "start_s": round(float(tv[0]), 3),
    }
    return track.replace(metadata={**track.metadata, "capture": report}), report


#: Video and capture rates a measured rate is snapped to when within 0.2 %.
STANDARD_RATES = (23.976, 24.0, 25.0, 29.97, 30.0, 50.0, 59.94, 60.0, 100.0, 120.0)


def capture_rate(times: np.ndarray) -> float:
    """Frame rate of increasing time stamps with drops and rounding (e.g. OpenFace's 1 ms).

    The mean of the steps one frame long (within half a median step of it) numbers the
    frames; the period is then the slope of a least-squares line through (frame number,
    time), which averages the stamps' rounding away; a rate within 0.2 % of a standard one
    (29.97, 30, 60 ...) is taken as the nearest.

    >>> round(capture_rate(np.round(np.arange(100) / 30.0, 3)), 6)
    30.0
    """
    t = np.asarray(times, dtype=np.float64)
    steps = np.diff(t)
    median = float(np.median(steps[steps > 0]))
    single = steps[(steps > 0.5 * median) & (steps < 1.5 * median)]  # one frame apart
    period = float(single.mean())  # rounding of the stamps averages out
    frames = np.round((t - t[0]) / period)
    if frames[-1] > 0:
        period = float(np.polyfit(frames, t, 1)[0])
    rate = 1.0 / period
    nearest = min(STANDARD_RATES, key=lambda r: abs(rate - r) / r)
    return nearest if abs(rate - nearest) <= 0.002 * nearest else rate


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[start, end)`` index pairs of the runs of True in ``mask``."""
    padded = np.r_[False, mask, False].astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]
