"""Per-frame latency of the live head-and-eye generator (head + gaze + eyelids), on one core.

Runs the streaming generator of ``app.stimuli.live`` with the shipped default model over the
demo speech's features (tiled to ``--frames`` frames) one frame at a time and prints the
latency distribution of ``LiveGenerator.step``; then the same from audio, one frame's block of
samples at a time (``push_audio``: causal pitch/intensity + the step). Targets:
median <= 1 ms, 99th percentile <= 3 ms per frame.

    PYTHONPATH=$PWD python benchmarks/bench_live.py [--frames 6000] [--model PATH]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def _figures(name: str, seconds: list[float]) -> None:
    ms = np.array(seconds) * 1e3
    print(
        f"{name:<28} frames {len(ms):6d}  median {np.median(ms):.3f} ms  "
        f"p90 {np.percentile(ms, 90):.3f} ms  p99 {np.percentile(ms, 99):.3f} ms  "
        f"max {ms.max():.3f} ms  mean {ms.mean():.3f} ms"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=6000)
    parser.add_argument("--model", type=Path, default=None)
    parser.add_argument("--core", type=int, default=0)
    args = parser.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {args.core})

    from app.stimuli.live.condition import DEFAULT_MODEL_PATH
    from app.stimuli.live.modelfile import load_model
    from app.stimuli.live.stream import LiveGenerator
    from app.stimuli.speech import extract_features, load_audio

    model = load_model(args.model or DEFAULT_MODEL_PATH)
    wav = ROOT / "app" / "data" / "demo" / "speech.wav"
    feats = extract_features(wav, model.fps, pitch_ceiling=300.0)
    reps = int(np.ceil(args.frames / feats.n_frames))
    f0 = np.tile(feats.f0, reps)[: args.frames]
    intensity = np.tile(feats.intensity, reps)[: args.frames]
    print(
        f"model: {args.model or DEFAULT_MODEL_PATH.relative_to(ROOT)} "
        f"({model.head.voiced.lam00.shape[1]} components x 5 GMMs, "
        f"{model.head.n_iter} Langevin steps), fps {model.fps:g}, one core (#{args.core}), "
        f"numpy {np.__version__}"
    )

    gen = LiveGenerator(model, seed=0)
    for t in range(200):  # warm-up
        gen.step(float(f0[t]), float(intensity[t]))
    gen = LiveGenerator(model, seed=0)
    clock = time.perf_counter
    times = []
    for t in range(args.frames):
        a = clock()
        gen.step(float(f0[t]), float(intensity[t]))
        times.append(clock() - a)
    _figures("features -> frame (step)", times)

    samples, sr = load_audio(wav)
    audio = np.tile(samples, reps)
    hop = int(round(sr / model.fps))
    gen = LiveGenerator(model, seed=0)
    times = []
    for start in range(0, min(len(audio), args.frames * hop), hop):
        a = clock()
        gen.push_audio(audio[start : start + hop], sr)
        times.append(clock() - a)
    _figures(f"audio block ({hop} samples)", times)


if __name__ == "__main__":
    main()
