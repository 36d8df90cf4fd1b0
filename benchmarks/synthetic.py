"""Synthetic speech for the benchmarks: a voiced harmonic tone with a gliding F0, syllable-rate
amplitude bursts and a pause every 4 s, so pitch and intensity trackers have work like speech's."""

from __future__ import annotations

import wave
from pathlib import Path

import numpy as np


def write_speech(path: str | Path, seconds: float, rate: int = 16000) -> Path:
    """Write ``seconds`` of synthetic mono 16-bit speech to ``path`` (a WAV file)."""
    t = np.arange(int(rate * seconds)) / rate
    f0 = 140 + 40 * np.sin(2 * np.pi * 0.3 * t)
    phase = 2 * np.pi * np.cumsum(f0) / rate
    env = (np.sin(2 * np.pi * 3.5 * t) > -0.3) * ((t % 4) < 3)
    x = 0.2 * env * sum(np.sin(k * phase) / k for k in range(1, 6)) / 2
    path = Path(path)
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(np.round(x * 32767).astype("<i2").tobytes())
    return path
