"""Held-out figures of the live head-and-eye generator: the expectation synthesis against the
Langevin draw it replaced.

Builds the standard split of :func:`app.stimuli.live.evaluation.held_out_split` on the demo
speech (training takes in the training voices with reference-speaker motion of seeds 0-2; test
takes in other voices with seeds 100-103; ``--reference-version``, default 1), trains the model
as shipped (per-speaker normalisation; expectation synthesis) and as before (training-scale
normalisation; the per-frame Langevin draw of eq. 3, which gives the earlier code's frames), and
prints per channel: sd (deg), the ground truth's, their ratio, the share of variance above 4 Hz
(generated, truth), the correlation, and the blink rates. ``benchmarks/bench_live_speech.py``
compares with RANDOM and ARX, with intervals.

    PYTHONPATH=$PWD python benchmarks/bench_live_heldout.py [--seconds 120] [--seeds 2]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=120.0)
    parser.add_argument("--train-takes", type=int, default=3)
    parser.add_argument("--test-takes", type=int, default=4)
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--reference-version", type=int, default=1)
    args = parser.parse_args()

    from app.stimuli.live.evaluation import evaluate_held_out, held_out_split
    from app.stimuli.live.model import train_live_model
    from app.stimuli.speech import load_sound

    sound, _ = load_sound(ROOT / "app" / "data" / "demo" / "speech.wav")
    split = held_out_split(
        sound,
        train_takes=args.train_takes,
        test_takes=args.test_takes,
        seconds=args.seconds,
        reference_version=args.reference_version,
    )
    print(
        f"train {len(split.train)} x {args.seconds:g} s, test {len(split.test)} x "
        f"{args.seconds:g} s, {args.seeds} generation seeds, reference speaker "
        f"v{args.reference_version}"
    )
    for label, train_options, options in (
        ("expectation synthesis, per-speaker normalisation (default)", {}, {}),
        (
            "Langevin draw, training-scale normalisation (before)",
            {"speaker_norm_s": 0},
            {"synthesis": "langevin"},
        ),
    ):
        start = time.perf_counter()
        model = train_live_model(
            [f for f, _ in split.train], [t for _, t in split.train], **train_options
        )
        figures = evaluate_held_out(model, split.test, seeds=range(args.seeds), **options)
        print(f"\n{label} ({time.perf_counter() - start:.1f} s)")
        print(figures.table())


if __name__ == "__main__":
    main()
