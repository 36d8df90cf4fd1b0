"""Speech features per video frame: the input every speech-driven condition reads.

Extraction (Praat's algorithms through praat-parselmouth) and conditioning (thesis sec.
4.3.4.1) live in :mod:`app.stimuli.speech`; this module holds only the type they produce, so
that the conditions, the live generator and the renderer can share it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(eq=False)
class SpeechFeatures:
    """Per-frame speech features at the video frame rate.

    Attributes
    ----------
    fps : frames per second; frame i describes the audio around time i / fps.
    f0 : raw F0 in Hz, 0 where unvoiced (Praat autocorrelation pitch).
    intensity : intensity in dB (Praat, re 2e-5 Pa with samples taken as pascals).
    f0_conditioned : unvoiced gaps filled by a cubic spline through the voiced frames, clipped
        to [0, max observed F0] (thesis sec. 4.3.4.1).
    metadata : audio path, sample rate, duration, channel handling, pitch floor/ceiling.
    """

    fps: float
    f0: np.ndarray
    intensity: np.ndarray
    f0_conditioned: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.f0)
        for name in ("intensity", "f0_conditioned"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"{name} has {len(getattr(self, name))} frames, f0 has {n}")

    @property
    def n_frames(self) -> int:
        return len(self.f0)

    @property
    def voiced(self) -> np.ndarray:
        """Boolean mask of voiced frames (raw F0 > 0)."""
        return np.asarray(self.f0) > 0

    def slice(self, start: int, stop: int) -> SpeechFeatures:
        """Frames ``start:stop`` as new features (for held-out splits and streaming)."""
        return SpeechFeatures(
            self.fps, self.f0[start:stop].copy(), self.intensity[start:stop].copy(),
            self.f0_conditioned[start:stop].copy(), dict(self.metadata),
        )
