"""The speech input of the live generator: pitch and loudness per frame, scaled, and the mode.

Le, Ma & Deng 2012 drive every module with two prosody features per frame, pitch ``p_t`` and
loudness ``l_t`` (sec. 4, "Speech feature extraction"). Here:

- pitch is F0 in semitones re 100 Hz, ``12 log2(f0 / 100)``; a frame without F0 (``f0 <= 0``)
  is *unvoiced* and has no pitch coordinate (the head model then uses its unvoiced mixtures,
  see :mod:`app.stimuli.live.head`);
- loudness is the intensity in dB re 2e-5 Pa floored at :data:`LOUDNESS_FLOOR_DB` (digital
  silence comes out of Praat near -300 dB, which would dominate any standardisation);
- both contours are smoothed by the paper's contour filter (sec. 4, "a contour smoothing
  filter with a window size of 3 frames (0.125 second)", at its 24 fps). The window is a time,
  :data:`SMOOTH_S`, so it is :func:`smooth_frames` ``= round(0.125 fps)`` frames: 3 at 24 fps,
  4 at 30 fps, 8 at 60 fps. Here it is a causal moving average over the current and the
  previous frames (:func:`smooth_contour`, :class:`ContourSmoother`), so that a live stream
  can apply it: the paper's generator reads only past and current speech (sec. 5.2).
  Unvoiced frames stay unvoiced; a voiced frame averages the voiced frames of its window;
- both are standardised per speaker (:class:`SpeakerNorm`): by exponentially weighted running
  means and standard deviations of the speech so far (time constant :data:`SPEAKER_NORM_S`;
  pitch over voiced frames), which start from the training data's (:class:`SpeechScale`,
  weighted as :data:`SPEAKER_PRIOR_S` of speech) and forget them as the speaker's own speech
  comes in. Causal, so a live stream can apply it, and
  the same in training (per take) as in generation. *Departure* (docs/reference/live.md):
  the paper standardises nothing per speaker and names "properly normalizing speech features"
  as the way to speaker independence (sec. 9); a held-out voice whose pitch lies outside the
  training voices' otherwise reads as constantly "high" (measured, held out: the head pitch
  expectation's r with the truth 0.33 -> 0.41 and 0.38 -> 0.48 on the reference speaker's
  versions 1 and 2, benchmarks/bench_live_diagnosis.py);
- the blink model's *mode* (sec. 7.1: talking or listening) is decided from loudness alone:
  talking while some frame of the last ``window_s`` seconds reached the talking threshold.

Example
-------
>>> import numpy as np
>>> scale = SpeechScale.fit(np.array([100.0, 200.0, 0.0]), np.array([60.0, 70.0, 20.0]))
>>> round(float(semitones(np.array([200.0]))[0]), 6)
12.0
>>> scale.threshold_db
45.0
>>> smooth_frames(24.0), smooth_frames(30.0)
(3, 4)
>>> smooth_contour(np.array([0.0, 0.0, 30.0, 30.0, 30.0]), 3).tolist()
[0.0, 0.0, 10.0, 20.0, 30.0]
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

_X = TypeVar("_X", float, np.ndarray)

#: Loudness below this (dB re 2e-5 Pa) is treated as this: quieter than any room.
LOUDNESS_FLOOR_DB = 0.0
#: The talking threshold sits this many dB below the median loudness of voiced training frames.
TALK_MARGIN_DB = 20.0
#: Standardised inputs are clipped to this many sd: the mixtures know nothing beyond, and a
#: wild reading (a clipped microphone, a glitch) must not throw the head or the eyes.
Z_LIMIT = 6.0
#: Width of the contour smoothing filter, seconds (Le, Ma & Deng 2012 sec. 4: 3 frames at 24 fps).
SMOOTH_S = 0.125
#: Time constant of the per-speaker normalisation, seconds: long against an utterance (a few
#: seconds), so that a phrase's rises and falls stay in the features.
SPEAKER_NORM_S = 30.0
#: The training statistics start the per-speaker ones with the weight of this much speech,
#: seconds: enough to steady the first syllables, little against a minute of the speaker.
SPEAKER_PRIOR_S = 2.0
#: The per-speaker standard deviation is kept above this share of the training data's.
MIN_SD_SHARE = 0.25


def smooth_frames(fps: float, seconds: float = SMOOTH_S) -> int:
    """Frames of the contour smoothing window at ``fps``: ``round(seconds * fps)``, at least 1."""
    return max(1, int(round(seconds * fps)))


def semitones(f0: np.ndarray) -> np.ndarray:
    """F0 in Hz -> semitones re 100 Hz; NaN where unvoiced (``f0 <= 0``)."""
    f0 = np.asarray(f0, dtype=np.float64)
    out = np.full(f0.shape, np.nan)
    voiced = f0 > 0
    out[voiced] = 12.0 * np.log2(f0[voiced] / 100.0)
    return out


def loudness(intensity_db: np.ndarray) -> np.ndarray:
    """Intensity in dB floored at :data:`LOUDNESS_FLOOR_DB` (NaN counts as the floor)."""
    x = np.nan_to_num(np.asarray(intensity_db, dtype=np.float64), nan=LOUDNESS_FLOOR_DB)
    return np.maximum(x, LOUDNESS_FLOOR_DB)


def smooth_contour(x: np.ndarray, width: int) -> np.ndarray:
    """Causal moving average of a contour: each frame the mean of the finite values among it
    and the ``width - 1`` frames before it; NaN (unvoiced) frames stay NaN.

    The sums are taken in the order :class:`ContourSmoother` takes them, so a stream gives
    bit-identical values.
    """
    x = np.asarray(x, dtype=np.float64)
    finite = np.isfinite(x)
    total = np.where(finite, x, 0.0)
    count = finite.astype(np.float64)
    for lag in range(1, max(int(width), 1)):
        total[lag:] = total[lag:] + np.where(finite[:-lag], x[:-lag], 0.0)
        count[lag:] += finite[:-lag]
    out = np.full(x.shape, np.nan)
    out[finite] = total[finite] / count[finite]
    return out


class ContourSmoother:
    """Streaming form of :func:`smooth_contour`: feed one frame, get its smoothed value."""

    def __init__(self, width: int) -> None:
        self._past: deque[float] = deque(maxlen=max(int(width), 1) - 1)

    def step(self, x: float) -> float:
        finite = x == x
        total, count = (x, 1.0) if finite else (0.0, 0.0)
        for v in reversed(self._past):
            if v == v:
                total, count = total + v, count + 1.0
        if self._past.maxlen:
            self._past.append(x)
        return total / count if finite else float("nan")


def smoothed_inputs(
    f0: np.ndarray, intensity_db: np.ndarray, fps: float, seconds: float = SMOOTH_S
) -> tuple[np.ndarray, np.ndarray]:
    """Pitch (semitones, NaN unvoiced) and loudness (dB) of one take at ``fps``, smoothed
    causally over ``seconds`` (:func:`smooth_frames`)."""
    width = smooth_frames(fps, seconds)
    return smooth_contour(semitones(f0), width), smooth_contour(loudness(intensity_db), width)


@dataclass(frozen=True)
class SpeechScale:
    """Standardisation of pitch (semitones) and loudness (dB), and the talking threshold."""

    pitch_mean: float
    pitch_std: float
    loud_mean: float
    loud_std: float
    threshold_db: float

    @classmethod
    def fit(cls, f0: np.ndarray, intensity_db: np.ndarray) -> SpeechScale:
        """Scale from training frames: pitch over voiced frames, loudness over all frames."""
        return cls.fit_contours(semitones(f0), loudness(intensity_db))

    @classmethod
    def fit_contours(cls, pitch_st: np.ndarray, loud_db: np.ndarray) -> SpeechScale:
        """:meth:`fit` from pitch in semitones (NaN unvoiced) and floored loudness in dB."""
        voiced = np.isfinite(pitch_st)
        st = np.asarray(pitch_st)[voiced]
        loud = np.asarray(loud_db, dtype=np.float64)
        pitch_mean = float(st.mean()) if st.size else 0.0
        pitch_std = float(st.std()) if st.size > 1 else 1.0
        ref = float(np.median(loud[voiced])) if voiced.any() else float(np.median(loud))
        return cls(
            pitch_mean,
            pitch_std if pitch_std > 1e-6 else 1.0,
            float(loud.mean()),
            float(loud.std()) if loud.std() > 1e-6 else 1.0,
            ref - TALK_MARGIN_DB,
        )

    def pitch_z(self, pitch_st: _X) -> _X:
        """Standardised pitch from semitones, within +/- :data:`Z_LIMIT`; NaN where
        unvoiced."""
        return np.clip((pitch_st - self.pitch_mean) / self.pitch_std, -Z_LIMIT, Z_LIMIT)

    def loud_z(self, loud_db: _X) -> _X:
        """Standardised loudness from floored dB, within +/- :data:`Z_LIMIT`."""
        return np.clip((loud_db - self.loud_mean) / self.loud_std, -Z_LIMIT, Z_LIMIT)

    def to_array(self) -> np.ndarray:
        return np.array(
            [self.pitch_mean, self.pitch_std, self.loud_mean, self.loud_std, self.threshold_db]
        )

    @classmethod
    def from_array(cls, a: np.ndarray) -> SpeechScale:
        return cls(*(float(v) for v in a))


def talking_mode(
    intensity_db: np.ndarray, threshold_db: float, fps: float, window_s: float = 0.5
) -> np.ndarray:
    """Causal talking/listening mode per frame (sec. 7.1): True while any of the frames of the
    last ``window_s`` seconds (the current one included) reached ``threshold_db``.

    The streaming generator computes the same thing incrementally; this vectorised form is for
    training (labelling the ground truth's blinks) and tests.
    """
    loud = loudness(intensity_db) >= threshold_db
    n = len(loud)
    w = max(1, int(round(window_s * fps)))
    idx = np.where(loud, np.arange(n), -(10**9))
    last = np.maximum.accumulate(idx) if n else idx
    return (np.arange(n) - last) < w


class _RunningMoments:
    """Exponentially weighted mean and variance of a stream (forgetting factor ``forget`` per
    update), pooled with a prior of the given mean and sd whose weight ``prior_weight``
    (updates) is forgotten at the same rate. The variance is the pooled *within* variance
    (the prior's and the data's own, weighted), so a speaker whose mean lies far from the
    prior's gets its own spread at once instead of one inflated by the distance. Sums are of
    ``x - prior mean``, so they do not lose precision to a large mean."""

    def __init__(self, mean: float, sd: float, forget: float, prior_weight: float) -> None:
        self._centre, self._var0 = mean, sd * sd
        self._a = forget
        self._w0 = max(prior_weight, 1.0)
        self._w, self._s, self._q = 0.0, 0.0, 0.0
        self._floor = (MIN_SD_SHARE * sd) ** 2

    def update(self, x: float) -> None:
        # a wild reading (a glitch, a clipped microphone) moves the statistics as one at the
        # current mean +/- Z_LIMIT sd would
        m, sd = self.mean, self.sd
        x = min(max(x, m - Z_LIMIT * sd), m + Z_LIMIT * sd)
        d = x - self._centre
        self._w0 *= self._a
        self._w = self._a * self._w + 1.0
        self._s = self._a * self._s + d
        self._q = self._a * self._q + d * d

    @property
    def mean(self) -> float:
        return self._centre + self._s / (self._w0 + self._w)

    @property
    def sd(self) -> float:
        within = self._q - self._s * self._s / self._w if self._w > 0 else 0.0
        var = (self._w0 * self._var0 + max(within, 0.0)) / (self._w0 + self._w)
        return math.sqrt(max(var, self._floor))


class SpeakerNorm:
    """Causal per-speaker standardisation of pitch (semitones, NaN unvoiced) and loudness (dB).

    Feed one frame, get its standardised ``(pitch_z, loud_z)``: each frame first updates the
    running statistics (pitch on voiced frames only), then is standardised by them and clipped
    to +/- :data:`Z_LIMIT`. The statistics start as ``scale``'s with the weight of
    :data:`SPEAKER_PRIOR_S` of frames. ``seconds`` None or 0: the training statistics alone
    (``scale``), as before per-speaker normalisation existed.
    """

    def __init__(self, scale: SpeechScale, fps: float, seconds: float | None = SPEAKER_NORM_S):
        self.scale = scale
        self.adaptive = bool(seconds)
        forget = math.exp(-1.0 / (seconds * fps)) if seconds else 0.0
        prior = SPEAKER_PRIOR_S * fps
        self._pitch = _RunningMoments(scale.pitch_mean, scale.pitch_std, forget, prior)
        self._loud = _RunningMoments(scale.loud_mean, scale.loud_std, forget, prior)

    def step(self, pitch_st: float, loud_db: float) -> tuple[float, float]:
        if not self.adaptive:
            return float(self.scale.pitch_z(pitch_st)), float(self.scale.loud_z(loud_db))
        voiced = pitch_st == pitch_st
        if voiced:
            self._pitch.update(pitch_st)
        self._loud.update(loud_db)
        p, lo = self._pitch, self._loud
        pz = min(max((pitch_st - p.mean) / p.sd, -Z_LIMIT), Z_LIMIT) if voiced else float("nan")
        lz = min(max((loud_db - lo.mean) / lo.sd, -Z_LIMIT), Z_LIMIT)
        return pz, lz


def speaker_normalised(
    pitch_st: np.ndarray,
    loud_db: np.ndarray,
    scale: SpeechScale,
    fps: float,
    seconds: float | None = SPEAKER_NORM_S,
) -> tuple[np.ndarray, np.ndarray]:
    """:class:`SpeakerNorm` over one take's contours (training): the same values, frame by
    frame, as the streaming generator computes."""
    if not seconds:
        return scale.pitch_z(np.asarray(pitch_st)), scale.loud_z(np.asarray(loud_db))
    norm = SpeakerNorm(scale, fps, seconds)
    out = np.array(
        [norm.step(float(p), float(lo)) for p, lo in zip(pitch_st, loud_db, strict=True)]
    )
    if len(out) == 0:
        return np.zeros(0), np.zeros(0)
    return out[:, 0], out[:, 1]
