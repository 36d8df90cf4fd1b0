"""Benchmark: all four conditions for 60 s of speech, F0 extraction included (target < 2 s)."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
from synthetic import write_speech  # benchmarks/synthetic.py, beside this script

from app.stimuli.generate import generate_conditions
from app.stimuli.reference_speaker import synthesize_reference
from app.stimuli.speech import extract_features


def main() -> None:
    with tempfile.TemporaryDirectory() as d:
        wav = write_speech(Path(d) / "speech.wav", 60.0)
        gt = synthesize_reference(extract_features(wav), seed=0)
        times = []
        for _ in range(3):
            start = time.perf_counter()
            generate_conditions(wav, ground_truth=gt, normalize=True)
            times.append(time.perf_counter() - start)
    print(
        f"all four conditions, 60 s of speech (F0, fit, measures): "
        f"best {min(times):.3f} s, median {np.median(times):.3f} s (target < 2 s)"
    )


if __name__ == "__main__":
    main()
