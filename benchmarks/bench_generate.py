"""Benchmark: ``facepair stimuli generate`` for 600 s of speech, three conditions, CLI defaults.

The command a researcher runs for a long recording: ``--conditions none,random,speech_driven``
with every default (shared generated eyes from the live model, shared lower face, the summary
and its plot), timed from outside as whole processes (start-up and imports included), CPU
time as the system accounts it.

The comparator is an earlier release of facepair running the same command on the same file:
``--baseline DIR`` names its checkout (``git worktree add DIR <commit>``), and the two run in
alternating rounds. Without it the script prints this build's figures beside the previous
release's as logged in docs/benchmarks.md (``PREVIOUS``: the build before generated eyes were
shared, which drew none).

    PYTHONPATH=$PWD python benchmarks/bench_generate.py
    git worktree add /tmp/before 6a4e3e5~1
    PYTHONPATH=$PWD python benchmarks/bench_generate.py --baseline /tmp/before --rounds 5
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from synthetic import write_speech  # benchmarks/synthetic.py, beside this script

REPO = Path(__file__).resolve().parent.parent
#: CPU seconds of the same command at 6a4e3e5~1 (2026-12-03, eyes still): median of 5
#: alternating runs on 2026-12-07 (docs/benchmarks.md, "Stimuli and the live model").
PREVIOUS = {"commit": "6a4e3e5~1", "cpu_s": 2.76}


def _one(repo: Path, audio: Path, out: Path) -> tuple[float, float]:
    """(wall s, CPU s) of one ``stimuli generate`` of ``repo``'s code, a child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(
        [
            sys.executable,
            "-c",
            "from app.cli import main; main()",
            "stimuli",
            "generate",
            "--audio",
            str(audio),
            "--conditions",
            "none,random,speech_driven",
            "--out",
            str(out),
        ],
        check=True,
        capture_output=True,
        cwd=repo,
        env={**os.environ, "PYTHONPATH": str(repo)},
    )
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=600.0)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--baseline", type=Path, help="checkout of an earlier release")
    args = parser.parse_args()
    print(f"load average at the start: {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    with tempfile.TemporaryDirectory() as tmp:
        audio = write_speech(Path(tmp) / "speech.wav", args.seconds)
        sides = [("this build", REPO)] + ([("baseline", args.baseline)] if args.baseline else [])
        runs: dict[str, list[tuple[float, float]]] = {name: [] for name, _ in sides}
        for name, repo in sides:  # one warm-up each
            _one(repo, audio, Path(tmp) / f"warm-{len(runs[name])}")
        for k in range(args.rounds):
            for name, repo in sides:
                wall, cpu = _one(repo, audio, Path(tmp) / f"{name}-{k}".replace(" ", "-"))
                runs[name].append((wall, cpu))
                print(f"  round {k + 1} {name:<10} {wall:6.2f} s wall, {cpu:6.2f} s CPU")
    ours = statistics.median(c for _, c in runs["this build"])
    print(
        f"{args.seconds:.0f} s of speech, none + random + speech_driven, defaults: median "
        f"{statistics.median(w for w, _ in runs['this build']):.2f} s wall, {ours:.2f} s CPU"
    )
    if args.baseline:
        ratios = [a[1] / b[1] for a, b in zip(runs["this build"], runs["baseline"], strict=True)]
        print(
            f"CPU ratio this build / {args.baseline}: {statistics.median(ratios):.2f} "
            "(median of rounds; per round " + ", ".join(f"{r:.2f}" for r in ratios) + ")"
        )
    else:
        print(
            f"against the logged figure of {PREVIOUS['commit']} ({PREVIOUS['cpu_s']:.2f} s CPU, "
            f"another run): {ours / PREVIOUS['cpu_s']:.2f}x"
        )


if __name__ == "__main__":
    main()
