"""Benchmark: all four conditions for 60 s of speech, F0 extraction included (target < 2 s)."""

from __future__ import annotations

import tempfile
import time
import wave
from pathlib import Path

import numpy as np

from app.stimuli.generate import generate_conditions
from app.stimuli.reference_speaker import synthesize_reference
from app.stimuli.speech import extract_features


def main() -> None:
    sr, seconds = 16000, 60.0
    t = np.arange(int(sr * seconds)) / sr
    f0 = 140 + 40 * np.sin(2 * np.pi * 0.3 * t)
    phase = 2 * np.pi * np.cumsum(f0) / sr
    env = (np.sin(2 * np.pi * 3.5 * t) > -0.3) * ((t % 4) < 3)
    x = 0.2 * env * sum(np.sin(k * phase) / k for k in range(1, 6)) / 2
    with tempfile.TemporaryDirectory() as d:
        wav = Path(d) / "speech.wav"
        with wave.open(str(wav), "wb") as w:
            w.setnchannels(1)
            w.setsampwidth(2)
            w.setframerate(sr)
            w.writeframes(np.round(x * 32767).astype("<i2").tobytes())
        gt = synthesize_reference(extract_features(wav), seed=0)
        times = []
        for _ in range(3):
            start = time.perf_counter()
            generate_conditions(wav, ground_truth=gt, normalize=True)
            times.append(time.perf_counter() - start)
    print(f"all four conditions, 60 s of speech (F0, fit, measures): "
          f"best {min(times):.3f} s, median {np.median(times):.3f} s (target < 2 s)")


if __name__ == "__main__":
    main()
