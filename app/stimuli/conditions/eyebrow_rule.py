"""The speech-driven eyebrow rule (thesis sec. 4.3.4.1).

"The rising edges [of F0Conditioned] were analyzed to determine if a pre-set limit of 207Hz
was crossed. If such condition occurred, an eyebrow-rising event was automatically triggered.
The eyebrow FAP displacement magnitude was determined as a scaled version of the fundamental
frequency signal, with an appropriate offset value. In addition, the eyebrow displacement was
maintained for a minimum of 300ms and terminated once the energy level dropped below 45dB with
a gradual motion to neutral state that lasted three additional video frames."

Choices where the text leaves room (documented in ``docs/stimuli.md``):

- A raise starts on frame ``k`` when ``F0c[k-1] < threshold <= F0c[k]``.
- It is held on frames ``k .. r-1``, where ``r`` is the first frame at or after
  ``k + ceil(min_hold * fps)`` whose intensity is below the intensity threshold (or the end).
- Its size is ``gain * F0peak + offset`` (clipped at 0), ``F0peak`` the highest conditioned F0
  during the minimum hold: one size per raise, so a raise is a held pose, as in the thesis
  figures, and a higher accent gives a higher raise.
- Release: frames ``r, r+1, r+2`` ramp down (3/4, 1/2, 1/4 of the size); frame ``r+3`` is
  neutral.
- A new crossing during a raise extends it (the minimum hold restarts there); a crossing during
  the release ramp starts a new raise.

Example
-------
>>> f0 = np.r_[np.full(5, 150.0), np.full(20, 250.0)]
>>> inten = np.r_[np.full(20, 60.0), np.full(5, 30.0)]
>>> eyebrow_raise_events(f0, inten, 30.0)
[(5, 20)]
"""

from __future__ import annotations

import math

import numpy as np

#: Thesis defaults (sec. 4.3.4.1). The dB threshold depends on recording gain: set it per setup.
F0_THRESHOLD_HZ = 207.0
INTENSITY_THRESHOLD_DB = 45.0
MIN_HOLD_S = 0.3
RELEASE_FRAMES = 3


def rising_crossings(f0_conditioned: np.ndarray, threshold: float) -> np.ndarray:
    """Frames ``k`` where ``f0[k-1] < threshold <= f0[k]``."""
    f0 = np.asarray(f0_conditioned, dtype=np.float64)
    return np.flatnonzero((f0[:-1] < threshold) & (f0[1:] >= threshold)) + 1


def eyebrow_raise_events(f0_conditioned: np.ndarray, intensity: np.ndarray, fps: float, *,
                         f0_threshold: float = F0_THRESHOLD_HZ,
                         intensity_threshold: float = INTENSITY_THRESHOLD_DB,
                         min_hold_s: float = MIN_HOLD_S) -> list[tuple[int, int]]:
    """Raises as ``(start, release)`` frame pairs: held on ``start .. release-1``.

    ``release`` may equal the frame count (held to the end).
    """
    inten = np.asarray(intensity, dtype=np.float64)
    n = len(inten)
    hold = max(math.ceil(min_hold_s * fps - 1e-9), 1)
    # next_low[i]: first frame >= i with intensity below the threshold (n if none)
    low_at = np.where(inten < intensity_threshold, np.arange(n), n)
    next_low = np.r_[np.minimum.accumulate(low_at[::-1])[::-1], n]
    events: list[tuple[int, int]] = []
    for k in rising_crossings(f0_conditioned, f0_threshold).tolist():
        if events and k < events[-1][1]:
            start, _ = events[-1]
            events[-1] = (start, int(next_low[min(k + hold, n)]))
        else:
            events.append((k, int(next_low[min(k + hold, n)])))
    return events


def eyebrow_raise_sizes(f0_conditioned: np.ndarray, events: list[tuple[int, int]],
                        fps: float, min_hold_s: float = MIN_HOLD_S) -> np.ndarray:
    """``F0peak`` of each raise: the highest conditioned F0 during its minimum hold."""
    f0 = np.asarray(f0_conditioned, dtype=np.float64)
    hold = max(math.ceil(min_hold_s * fps - 1e-9), 1)
    return np.array([f0[s:min(s + hold, r) if r > s else s + 1].max() for s, r in events])


def eyebrow_contour(n_frames: int, events: list[tuple[int, int]], sizes: np.ndarray,
                    release_frames: int = RELEASE_FRAMES) -> np.ndarray:
    """Per-frame displacement: each raise held at its size, then a linear release ramp."""
    out = np.zeros(n_frames)
    ramp = 1.0 - np.arange(1, release_frames + 1) / (release_frames + 1)
    for (start, release), size in zip(events, sizes, strict=True):
        out[start:release] = size
        end = min(release + release_frames, n_frames)
        out[release:end] = size * ramp[: end - release]
    return out
