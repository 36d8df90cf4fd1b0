"""Causal pitch and loudness from a stream of audio blocks, one value pair per video frame.

The live generator must see only past and current audio (Le, Ma & Deng 2012, sec. 1 and 5.2:
"live speech"), so it cannot use the whole-file Praat analysis of :mod:`app.stimuli.speech`.
Frame ``i`` (time ``i / fps``) is analysed on the window of ``3 / pitch_floor`` seconds that
*ends* at that time (zeros before the first sample):

- intensity: the Hann-weighted mean square of the mean-removed window, in dB re 2e-5 Pa with
  samples taken as pascals (the convention of Praat's intensity);
- F0: the peak of the window's normalised autocorrelation divided by the window's own
  autocorrelation (Boersma 1993, the method behind Praat's ``to_pitch_ac``) between the lags of
  ``pitch_ceiling`` and ``pitch_floor``, with a small preference for higher candidates
  (``octave_cost`` per octave) and parabolic refinement. Voiced if the peak reaches
  ``voicing_threshold`` and the intensity ``silence_db``; otherwise F0 = 0.

It is a single-frame estimator without Praat's path finding, so octave jumps are possible on
rough voices; the generator only uses pitch through smooth mixture densities.

Example
-------
>>> import numpy as np
>>> sr = 16000
>>> t = np.arange(sr) / sr
>>> tone = 0.1 * np.sin(2 * np.pi * 150 * t) + 0.05 * np.sin(2 * np.pi * 300 * t)
>>> frames = AudioFrameStream(sr, 30.0).push(tone)
>>> round(frames[15][0])
150
"""

from __future__ import annotations

import numpy as np

_P_REF2 = (2e-5) ** 2


class AudioFrameStream:
    """Feed blocks of mono samples with :meth:`push`; get (f0 Hz, intensity dB) per frame."""

    def __init__(
        self,
        sample_rate: int,
        fps: float,
        *,
        pitch_floor: float = 75.0,
        pitch_ceiling: float = 600.0,
        voicing_threshold: float = 0.45,
        silence_db: float = 35.0,
        octave_cost: float = 0.01,
    ) -> None:
        if sample_rate <= 0 or fps <= 0 or not 0 < pitch_floor < pitch_ceiling:
            raise ValueError("need sample_rate > 0, fps > 0 and 0 < pitch_floor < ceiling")
        self.sample_rate = int(sample_rate)
        self.fps = float(fps)
        self.width = int(round(3.0 * sample_rate / pitch_floor))
        self.min_lag = max(2, int(np.floor(sample_rate / pitch_ceiling)))
        self.max_lag = min(self.width // 2, int(np.ceil(sample_rate / pitch_floor)))
        self.voicing_threshold = voicing_threshold
        self.silence_db = silence_db
        self._window = np.hanning(self.width + 2)[1:-1]
        self._wsum = float(self._window.sum())
        self._nfft = 1 << int(np.ceil(np.log2(2 * self.width)))
        rw = np.fft.irfft(np.abs(np.fft.rfft(self._window, self._nfft)) ** 2)[: self.max_lag + 2]
        self._rw = rw / rw[0]
        lags = np.arange(self.max_lag + 2, dtype=np.float64)
        with np.errstate(divide="ignore"):
            self._cost = octave_cost * np.log2(np.maximum(lags, 1.0) * pitch_floor / sample_rate)
        self._buf = np.zeros(self.width)
        self._buf_start = -self.width  # absolute index of _buf[0]
        self._received = 0
        self._next = 0  # next frame index

    def _frame_end(self, i: int) -> int:
        return int(round(i * self.sample_rate / self.fps))

    def push(self, samples: np.ndarray) -> list[tuple[float, float]]:
        """Append samples; return (f0, intensity) for each frame whose window is complete."""
        samples = np.asarray(samples, dtype=np.float64).ravel()
        self._buf = np.concatenate([self._buf, samples])
        self._received += len(samples)
        out = []
        while self._frame_end(self._next) <= self._received:
            end = self._frame_end(self._next) - self._buf_start
            out.append(self._analyse(self._buf[end - self.width : end]))
            self._next += 1
        keep_from = self._frame_end(self._next) - self.width - self._buf_start
        if keep_from > 0:
            self._buf = self._buf[keep_from:]
            self._buf_start += keep_from
        return out

    def _analyse(self, x: np.ndarray) -> tuple[float, float]:
        x = x - x.mean()
        xw = x * self._window
        power = float((xw * x).sum() / self._wsum)
        db = 10.0 * np.log10(power / _P_REF2) if power > 0 else -300.0
        if db < self.silence_db:
            return 0.0, db
        r = np.fft.irfft(np.abs(np.fft.rfft(xw, self._nfft)) ** 2)[: self.max_lag + 2]
        rn = r / r[0] / self._rw
        lo, hi = self.min_lag, self.max_lag
        seg = rn[lo : hi + 1] - self._cost[lo : hi + 1]
        k = int(np.argmax(seg)) + lo
        if rn[k] < self.voicing_threshold or k <= lo or k >= hi:
            return 0.0, db
        a, b, c = rn[k - 1], rn[k], rn[k + 1]
        denom = a - 2 * b + c
        shift = 0.5 * (a - c) / denom if denom < 0 else 0.0
        return float(self.sample_rate / (k + shift)), db
