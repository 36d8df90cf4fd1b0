"""The speech input of the live generator: pitch and loudness per frame, scaled, and the mode.

Le, Ma & Deng 2012 drive every module with two prosody features per frame, pitch ``p_t`` and
loudness ``l_t`` (sec. 4, "Speech feature extraction"). Here:

- pitch is F0 in semitones re 100 Hz, ``12 log2(f0 / 100)``; a frame without F0 (``f0 <= 0``)
  is *unvoiced* and has no pitch coordinate (the head model then uses its unvoiced mixtures,
  see :mod:`app.stimuli.live.head`);
- loudness is the intensity in dB re 2e-5 Pa floored at :data:`LOUDNESS_FLOOR_DB` (digital
  silence comes out of Praat near -300 dB, which would dominate any standardisation);
- both are standardised with the training data's mean and standard deviation
  (:class:`SpeechScale`);
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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Loudness below this (dB re 2e-5 Pa) is treated as this: quieter than any room.
LOUDNESS_FLOOR_DB = 0.0
#: The talking threshold sits this many dB below the median loudness of voiced training frames.
TALK_MARGIN_DB = 20.0


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
        st = semitones(f0)
        st = st[np.isfinite(st)]
        loud = loudness(intensity_db)
        voiced = np.asarray(f0) > 0
        pitch_mean = float(st.mean()) if st.size else 0.0
        pitch_std = float(st.std()) if st.size > 1 else 1.0
        ref = float(np.median(loud[voiced])) if voiced.any() else float(np.median(loud))
        return cls(pitch_mean, pitch_std if pitch_std > 1e-6 else 1.0, float(loud.mean()),
                   float(loud.std()) if loud.std() > 1e-6 else 1.0, ref - TALK_MARGIN_DB)

    def pitch_z(self, f0: np.ndarray) -> np.ndarray:
        """Standardised pitch; NaN where unvoiced."""
        return (semitones(f0) - self.pitch_mean) / self.pitch_std

    def loud_z(self, intensity_db: np.ndarray) -> np.ndarray:
        """Standardised loudness."""
        return (loudness(intensity_db) - self.loud_mean) / self.loud_std

    def to_array(self) -> np.ndarray:
        return np.array([self.pitch_mean, self.pitch_std, self.loud_mean, self.loud_std,
                         self.threshold_db])

    @classmethod
    def from_array(cls, a: np.ndarray) -> SpeechScale:
        return cls(*(float(v) for v in a))


def talking_mode(intensity_db: np.ndarray, threshold_db: float, fps: float,
                 window_s: float = 0.5) -> np.ndarray:
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
