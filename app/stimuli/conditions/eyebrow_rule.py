"""The speech-driven eyebrow rule (thesis sec. 4.3.4.1).

"The rising edges [of F0Conditioned] were analyzed to determine if a pre-set limit of 207Hz
was crossed. If such condition occurred, an eyebrow-rising event was automatically triggered.
The eyebrow FAP displacement magnitude was determined as a scaled version of the fundamental
frequency signal, with an appropriate offset value. In addition, the eyebrow displacement was
maintained for a minimum of 300ms and terminated once the energy level dropped below 45dB with
a gradual motion to neutral state that lasted three additional video frames."

Choices where the text leaves room (documented in ``docs/reference/stimuli.md``):

- A raise starts on frame ``k`` when ``F0c[k-1] < threshold <= F0c[k]``, counting only the
  frames that are voiced and at or above the intensity threshold: ``k`` must be such a frame,
  and ``k-1`` is the previous such frame (:func:`rising_crossings`), so the spline that eq. 35
  draws through a pause or an unvoiced stretch never starts a raise.
- It is held on frames ``k .. r-1``, where ``r`` is the first frame at or after
  ``k + ceil(min_hold * fps)`` whose intensity is below the intensity threshold (or the end).
- Its size is ``gain * F0peak + offset`` (clipped at 0), ``F0peak`` the highest conditioned F0
  during the minimum hold: one size per raise, so a raise is a held pose, as in the thesis
  figures, and a higher accent gives a higher raise.
- Size in FAP units (ENS): :func:`raise_size`, ``gain * F0peak + offset`` with the defaults
  chosen so that the raises lie in the thesis' range (Table 8: SPEECH_DRIVEN inner eyebrows
  mean 10-15, sd 17-22, which a held pose present about 30 % of the time reproduces with
  raises of 38-47 units): 35 units at the threshold, 0.2 units per Hz above it, capped at
  :data:`MAX_RAISE` so that a pitch error can never fold the brow.
- Onset and release: the raise ramps up over ``onset_frames`` (default 3: 1/4, 1/2, 3/4 of the
  size on frames ``k, k+1, k+2``) and down over the thesis' three frames (3/4, 1/2, 1/4 on
  ``r, r+1, r+2``; frame ``r+3`` neutral). The thesis states only the release; a one-frame
  jump of 40 units reads as a twitch, so the onset gets the same three frames.
- A new crossing during a raise extends it (the minimum hold restarts there). Departure: a
  crossing less than ``min_gap_s`` after a release starts no new raise (default
  :data:`MIN_GAP_S`, 0.5 s; 0 is the thesis' rule, where a crossing during the release ramp
  starts a new raise). In fast speech the pitch crosses the threshold on nearly every
  stressed syllable; without a gap the brows of a fast synthetic voice were up 52 % of the
  time, and brows that drop and rise again within half a second read as a flicker.

Example
-------
>>> f0 = np.r_[np.full(5, 150.0), np.full(20, 250.0)]
>>> inten = np.r_[np.full(20, 60.0), np.full(5, 30.0)]
>>> eyebrow_raise_events(f0, inten, 30.0)
[(5, 20)]
>>> raise_size(np.array([207.0, 257.0]), 207.0).tolist()
[35.0, 45.0]
"""

from __future__ import annotations

import math

import numpy as np

#: Thesis defaults (sec. 4.3.4.1). The dB threshold depends on recording gain: set it per setup.
F0_THRESHOLD_HZ = 207.0
INTENSITY_THRESHOLD_DB = 45.0
MIN_HOLD_S = 0.3
#: Shortest time from a release to the next raise, seconds (a departure, see below).
MIN_GAP_S = 0.5
RELEASE_FRAMES = 3
ONSET_FRAMES = 3
#: Raise size at the F0 threshold (FAP units, ENS) and its growth per Hz of F0 peak above it.
RAISE_AT_THRESHOLD = 35.0
RAISE_GAIN = 0.2
#: Largest raise, FAP units: about twice the thesis' typical raise.
MAX_RAISE = 80.0
#: A raise held longer than this (seconds) is reported: the intensity threshold may not suit.
LONG_HOLD_S = 4.0


def raise_size(
    f0_peak: np.ndarray,
    f0_threshold: float,
    *,
    gain: float = RAISE_GAIN,
    offset: float | None = None,
    max_raise: float = MAX_RAISE,
) -> np.ndarray:
    """Thesis sec. 4.3.4.1: "a scaled version of the fundamental frequency signal, with an
    appropriate offset", in ENS units: ``clip(gain * F0peak + offset, 0, max_raise)``.

    ``offset`` defaults to ``RAISE_AT_THRESHOLD - gain * f0_threshold``, so a raise whose peak
    just reaches the threshold is :data:`RAISE_AT_THRESHOLD` units whatever the speaker's F0.
    """
    if offset is None:
        offset = RAISE_AT_THRESHOLD - gain * f0_threshold
    return np.clip(gain * np.asarray(f0_peak, dtype=np.float64) + offset, 0.0, max_raise)


def rising_crossings(
    f0_conditioned: np.ndarray, threshold: float, eligible: np.ndarray | None = None
) -> np.ndarray:
    """Frames ``k`` where the conditioned F0 rises across ``threshold``.

    Without ``eligible``: ``f0[k-1] < threshold <= f0[k]``. With a boolean mask of the frames
    on which a raise may start, the rising edge is taken between consecutive eligible frames:
    ``k`` is eligible, ``f0[k] >= threshold`` and ``f0[j] < threshold`` at the previous
    eligible frame ``j``. Eq. 35's spline bridges pauses and unvoiced stretches with a curve
    the speaker never produced; a crossing on that curve starts no raise, and speech that
    resumes above the threshold after a pause that began below it does.

    >>> f0 = np.array([150.0, 180, 220, 260, 240.0])
    >>> rising_crossings(f0, 207.0).tolist()
    [2]
    >>> rising_crossings(f0, 207.0, np.array([True, True, False, False, True])).tolist()
    [4]
    """
    f0 = np.asarray(f0_conditioned, dtype=np.float64)
    if eligible is None:
        return np.flatnonzero((f0[:-1] < threshold) & (f0[1:] >= threshold)) + 1
    frames = np.flatnonzero(np.asarray(eligible, dtype=bool))
    at = f0[frames]
    return frames[1:][(at[:-1] < threshold) & (at[1:] >= threshold)]


def eyebrow_raise_events(
    f0_conditioned: np.ndarray,
    intensity: np.ndarray,
    fps: float,
    *,
    f0_threshold: float = F0_THRESHOLD_HZ,
    intensity_threshold: float = INTENSITY_THRESHOLD_DB,
    min_hold_s: float = MIN_HOLD_S,
    voiced: np.ndarray | None = None,
    min_gap_s: float = 0.0,
) -> list[tuple[int, int]]:
    """Raises as ``(start, release)`` frame pairs: held on ``start .. release-1``.

    A raise starts only on a frame that is voiced (``voiced``, the raw F0's voicing; every
    frame when ``None``) and at or above the intensity threshold, at a rising edge of the
    conditioned F0 between such frames (:func:`rising_crossings`): the thesis' rule reads the
    speaker's pitch, not the spline through a silence. ``release`` may equal the frame count
    (held to the end).
    """
    inten = np.asarray(intensity, dtype=np.float64)
    n = len(inten)
    hold = max(math.ceil(min_hold_s * fps - 1e-9), 1)
    # next_low[i]: first frame >= i with intensity below the threshold (n if none)
    low_at = np.where(inten < intensity_threshold, np.arange(n), n)
    next_low = np.r_[np.minimum.accumulate(low_at[::-1])[::-1], n]
    eligible = inten >= intensity_threshold
    if voiced is not None:
        eligible &= np.asarray(voiced, dtype=bool)
    gap = math.ceil(min_gap_s * fps - 1e-9)
    events: list[tuple[int, int]] = []
    for k in rising_crossings(f0_conditioned, f0_threshold, eligible).tolist():
        if events and events[-1][1] <= k < events[-1][1] + gap:
            continue
        if events and k < events[-1][1]:
            start, _ = events[-1]
            events[-1] = (start, int(next_low[min(k + hold, n)]))
        else:
            events.append((k, int(next_low[min(k + hold, n)])))
    return events


def eyebrow_raise_sizes(
    f0_conditioned: np.ndarray,
    events: list[tuple[int, int]],
    fps: float,
    min_hold_s: float = MIN_HOLD_S,
) -> np.ndarray:
    """``F0peak`` of each raise: the highest conditioned F0 during its minimum hold."""
    f0 = np.asarray(f0_conditioned, dtype=np.float64)
    hold = max(math.ceil(min_hold_s * fps - 1e-9), 1)
    return np.array([f0[s : min(s + hold, r) if r > s else s + 1].max() for s, r in events])


def eyebrow_contour(
    n_frames: int,
    events: list[tuple[int, int]],
    sizes: np.ndarray,
    release_frames: int = RELEASE_FRAMES,
    onset_frames: int = 0,
) -> np.ndarray:
    """Per-frame displacement: each raise ramps up over ``onset_frames``, is held at its size,
    then ramps down over ``release_frames`` (linear ramps, see the module docstring)."""
    out = np.zeros(n_frames)
    down = 1.0 - np.arange(1, release_frames + 1) / (release_frames + 1)
    up = np.arange(1, onset_frames + 1) / (onset_frames + 1)
    for (start, release), size in zip(events, sizes, strict=True):
        out[start:release] = size
        rise = min(onset_frames, release - start)
        out[start : start + rise] = size * up[:rise]
        end = min(release + release_frames, n_frames)
        out[release:end] = np.maximum(out[release:end], size * down[: end - release])
    return out


def hold_warnings(
    events: list[tuple[int, int]],
    fps: float,
    f0_threshold: float,
    f0_max: float,
    long_hold_s: float = LONG_HOLD_S,
) -> list[str]:
    """What a researcher should check: no raise at all, or raises held unusually long."""
    if not events:
        return [
            f"no eyebrow raise: conditioned F0 never rises across {f0_threshold:g} Hz "
            f"(its maximum is {f0_max:.0f} Hz); set the F0 threshold for this speaker "
            "or use 'auto'"
        ]
    long = [(s, r) for s, r in events if (r - s) / fps > long_hold_s]
    if not long:
        return []
    spans = ", ".join(f"{s / fps:.1f}-{r / fps:.1f} s" for s, r in long)
    return [
        f"eyebrow raise held longer than {long_hold_s:g} s ({spans}): intensity never "
        "fell below the release threshold; lower-level pauses or a higher threshold "
        "would end it"
    ]
