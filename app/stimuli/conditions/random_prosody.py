"""RANDOM (thesis sec. 4.3.3): head and eyebrow motion from fractal Perlin noise.

Thesis eq. 32-34 (:mod:`app.stimuli.perlin`): 6 octaves, persistence 0.8, the noise input a
function of the frame number. Eyebrows use one trajectory for all raise channels (left = right,
as the thesis' eyebrow FAPs) with negative values set to zero ("negative values were
neglected"); each head angle gets its own frame offset, so the three angles are uncorrelated.
The seed of the generator is the ``seed`` given to :meth:`RandomCondition.generate`.

Amplitudes (thesis sec. 5.2, experiment 1): by default RANDOM keeps its own amplitudes, the
Perlin constants below, taken from Table 8's RANDOM rows (the mean of S2 and S7): head sd
pitch 3590, yaw 4350, roll 3050 AU (about 2.1, 2.5 and 1.7 degrees) around the neutral pose,
eyebrow sd 12.5 ENS after the negative values are dropped. That is the condition whose larger
head motion made viewers prefer it to the ground truth in experiment 1. ``match_amplitudes=True``
(or the study-wide normalisation of sec. 5.3, :mod:`app.stimuli.normalize`) instead takes each
head angle's mean and sd, and each eyebrow channel's sd, from the ground truth. Lattice rates:
the first octave at 0.2 Hz for the head and 0.4 Hz for the eyebrows, so the sixth octave
(x 32) stays under the 15 Hz Nyquist rate of 30 fps video. The eyebrows driven are those of
the thesis, FAP 31-34 (inner = middle); the outer eyebrows stay neutral.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.stimuli.conditions.base import ConditionModel
from app.stimuli.fap import HEAD
from app.stimuli.perlin import frame_noise
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack

#: Perlin amplitude constants (Table 8, RANDOM, mean of S2 and S7): standard deviations of the
#: head angles in AU (1 deg = 1745 AU) and of the clipped eyebrow trajectory in ENS.
DEFAULT_STD = {48: 3590.0, 49: 4350.0, 50: 3050.0, 31: 12.5, 32: 12.5, 33: 12.5, 34: 12.5}
#: The eyebrow FAPs RANDOM drives (thesis sec. 4.3.1: inner and middle eyebrows).
BROW_CHANNELS: tuple[int, ...] = (31, 32, 33, 34)
#: Frame offsets of the head angles (thesis: "each head inclination ... a different
#: frameOffset"); far apart relative to the lattice spacing, so the trajectories are unrelated.
HEAD_OFFSETS = {48: 0, 49: 104_729, 50: 209_459}
EYEBROW_OFFSET = 314_159


class RandomCondition(ConditionModel):
    """Perlin-noise visual prosody: the baseline with natural frequency content."""

    name = "random"

    def __init__(
        self,
        *,
        octaves: int = 6,
        persistence: float = 0.8,
        head_frequency: float = 0.2,
        eyebrow_frequency: float = 0.4,
        match_amplitudes: bool = False,
    ) -> None:
        self.match_amplitudes = bool(match_amplitudes)
        self.octaves, self.persistence = int(octaves), float(persistence)
        self.head_frequency, self.eyebrow_frequency = (
            float(head_frequency),
            float(eyebrow_frequency),
        )
        self.target: dict[int, tuple[float | None, float]] = {
            c: (None, s) for c, s in DEFAULT_STD.items()
        }
        self.matched_to = ""

    def fit(self, features: SpeechFeatures, ground_truth: MotionTrack | None) -> RandomCondition:
        """With ``match_amplitudes``, take amplitudes from a reference track's statistics."""
        if ground_truth is None or not self.match_amplitudes:
            return self
        for c in (*HEAD, *BROW_CHANNELS):
            if c in ground_truth.channels:
                self.target[c] = (float(ground_truth[c].mean()), float(ground_truth[c].std()))
        self.matched_to = ground_truth.source or "reference track"
        return self

    def _noise(self, n: int, fps: float, frequency: float, offset: int, seed: int) -> np.ndarray:
        return frame_noise(
            n,
            fps,
            frequency=frequency,
            frame_offset=offset,
            seed=seed,
            octaves=self.octaves,
            persistence=self.persistence,
        )

    def generate(
        self, features: SpeechFeatures, *, seed: int = 0, ground_truth: MotionTrack | None = None
    ) -> MotionTrack:
        n, fps = features.n_frames, features.fps
        track = self.base_track(features, ground_truth)
        cols: dict[int, np.ndarray] = {}
        for c in HEAD:
            z = _standardise(self._noise(n, fps, self.head_frequency, HEAD_OFFSETS[c], seed))
            mean, std = self.target[c]
            cols[c] = (mean or 0.0) + std * z
        brow = np.maximum(self._noise(n, fps, self.eyebrow_frequency, EYEBROW_OFFSET, seed), 0)
        brow_sd = brow.std() if n else 0.0
        for c in BROW_CHANNELS:
            scale = self.target[c][1] / brow_sd if brow_sd > 0 else 0.0
            cols[c] = brow * scale
        meta = dict(
            track.metadata,
            seed=seed,
            amplitudes="matched to " + self.matched_to
            if self.matched_to
            else "Perlin constants (thesis Table 8)",
        )
        return track.with_channels(cols).replace(metadata=meta)

    def describe(self) -> dict[str, Any]:
        return {
            "octaves": self.octaves,
            "persistence": self.persistence,
            "head_frequency_hz": self.head_frequency,
            "eyebrow_frequency_hz": self.eyebrow_frequency,
            "amplitudes": self.matched_to or "Perlin constants (Table 8)",
            "target_mean_std": {c: list(v) for c, v in self.target.items()},
        }


def _standardise(x: np.ndarray) -> np.ndarray:
    if len(x) == 0:
        return x
    sd = x.std()
    return (x - x.mean()) / sd if sd > 0 else np.zeros_like(x)
