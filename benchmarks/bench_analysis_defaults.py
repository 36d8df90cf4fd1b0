"""Benchmark: ``facepair analyze votes.csv`` with its defaults against pandas reading the file.

The defaults are what a researcher runs: every statistic, bootstrap intervals from 1,000
resamples of the participants (per clip and pooled) and the mixed Bradley-Terry-Davidson
model with participant and clip random effects. The study is the common paired design:
participants x 10 clips x the 6 pairs of 4 conditions, sides at random, undecided votes
where the difference is small, participant x condition sd 0.2 and clip x condition sd 0.1
(log-worth units) on top of the conditions' worths. Alternating rounds, each in a fresh child
process (imports excluded from the times):

- comparator: ``pandas.read_csv(path)``;
- facepair: ``read_votes(path)`` and ``analyze(table)`` with the defaults.

Printed per size: the medians of wall and CPU time, the ratio facepair / comparator per
round (target: under 10 at 10,000 participants), the mixed model's variance updates, and
the growth: facepair's time per vote at the largest size over that at the smallest (1 is
linear).

Run from the repository root:

    PYTHONPATH=$PWD python benchmarks/bench_analysis_defaults.py                 # 1,000, 10,000
    PYTHONPATH=$PWD python benchmarks/bench_analysis_defaults.py --sizes 3000 --rounds 5
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
CONDITIONS = ("none", "random", "speech_driven", "ground_truth")
WORTH = (-0.8, 0.1, 0.35, 0.6)

_PEAK = """
def peak_kb():
    with open("/proc/self/status") as status:
        return next(int(l.split()[1]) for l in status if l.startswith("VmHWM"))
"""

_CHILD_PANDAS = (
    _PEAK
    + """
import json, sys, time
import pandas as pd
base = peak_kb()
start, cpu = time.perf_counter(), time.process_time()
frame = pd.read_csv(sys.argv[1])
wall, cpu = time.perf_counter() - start, time.process_time() - cpu
print(json.dumps({"wall": wall, "cpu": cpu, "peak_kb": peak_kb(), "base_kb": base}))
"""
)

_CHILD_FACEPAIR = (
    _PEAK
    + """
import json, sys, time
from app.analysis import analyze, read_votes
base = peak_kb()
start, cpu = time.perf_counter(), time.process_time()
table = read_votes(sys.argv[1])
read = time.perf_counter() - start
results = analyze(table)
wall, cpu = time.perf_counter() - start, time.process_time() - cpu
mixed = results["pooled"]["mixed_btd"]
print(json.dumps({"wall": wall, "cpu": cpu, "read": read, "votes": results["input"]["votes"],
                  "updates": mixed.get("iterations"), "peak_kb": peak_kb(), "base_kb": base}))
"""
)


def write_votes(path: Path, participants: int, seed: int = 1) -> int:
    """The simulated study as the export writes it; returns the number of votes."""
    import pandas as pd

    from app.analysis import write_votes_csv
    from app.analysis.scaling import JOD_SIGMA

    rng = np.random.default_rng(seed)
    clips, worth = 10, np.asarray(WORTH)
    pairs = [(a, b) for a in range(4) for b in range(a + 1, 4)]
    per = clips * len(pairs)
    p = np.repeat(np.arange(participants), per)
    a = np.tile(np.tile([x for x, _ in pairs], clips), participants)
    b = np.tile(np.tile([y for _, y in pairs], clips), participants)
    k = np.tile(np.repeat(np.arange(clips), len(pairs)), participants)
    swap = rng.random(len(p)) < 0.5
    left, right = np.where(swap, b, a), np.where(swap, a, b)
    person = rng.normal(0, 0.2, (participants, 4))
    clip = rng.normal(0, 0.1, (clips, 4))
    z = (
        worth[left]
        - worth[right]
        + person[p, left]
        - person[p, right]
        + clip[k, left]
        - clip[k, right]
        + JOD_SIGMA * rng.standard_normal(len(p))
    )
    names = np.array(CONDITIONS, dtype=object)
    frame = pd.DataFrame(
        {
            "participant": np.char.add("P", p.astype(str)),
            "clip": np.char.add("s", k.astype(str)),
            "left": names[left],
            "right": names[right],
            "choice": np.where(np.abs(z) < 0.3, "undecided", np.where(z > 0, "left", "right")),
            "study": "benchmark",
            "trial": np.tile(np.arange(1, per + 1), participants),
            "response_ms": 1500.0,
            "plays": 1,
            "presented_at": pd.Timestamp("2026-03-02T09:00:00Z"),
            "voted_at": pd.Timestamp("2026-03-02T09:00:01Z"),
        }
    )
    return write_votes_csv(frame, path)


def _child(code: str, path: Path) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    out = subprocess.run(
        [sys.executable, "-c", code, str(path)], capture_output=True, text=True, env=env, cwd=REPO
    )
    if out.returncode != 0:
        sys.exit(out.stderr[-2000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def compare(path: Path, rounds: int) -> dict[str, float]:
    size = path.stat().st_size
    _child(_CHILD_PANDAS, path), _child(_CHILD_FACEPAIR, path)  # warm the page cache
    bare, ours = [], []
    for k in range(rounds):
        sides = (("pandas", _CHILD_PANDAS, bare), ("facepair", _CHILD_FACEPAIR, ours))
        for name, code, into in sides:
            r = _child(code, path)
            into.append(r)
            extra = f", reading {r['read']:.2f} s" if "read" in r else ""
            print(
                f"  round {k + 1} {name:<8} {r['wall']:6.2f} s (CPU {r['cpu']:.2f} s){extra}, "
                f"peak {r['peak_kb'] / 1024:5.0f} MB"
            )
    walls = [o["wall"] / b["wall"] for b, o in zip(bare, ours, strict=True)]
    cpus = [o["cpu"] / b["cpu"] for b, o in zip(bare, ours, strict=True)]
    t_ours = statistics.median(r["wall"] for r in ours)
    print(
        f"pandas.read_csv      median {statistics.median(r['wall'] for r in bare):6.2f} s wall, "
        f"{statistics.median(r['cpu'] for r in bare):.2f} s CPU"
    )
    print(
        f"facepair (defaults)  median {t_ours:6.2f} s wall, "
        f"{statistics.median(r['cpu'] for r in ours):.2f} s CPU; the mixed model's variance "
        f"updates: {ours[0]['updates']}"
    )
    print(
        f"ratio facepair / pandas: wall {statistics.median(walls):.1f} (per round "
        + ", ".join(f"{x:.1f}" for x in walls)
        + f"), CPU {statistics.median(cpus):.1f} (per round "
        + ", ".join(f"{x:.1f}" for x in cpus)
        + "); target under 10 at 10,000 participants"
    )
    above = max(r["peak_kb"] - r["base_kb"] for r in ours) * 1024
    print(f"facepair peak RSS above its imports {above / 1e6:.0f} MB = {above / size:.1f}x the CSV")
    return {"wall": t_ours, "votes": ours[0]["votes"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    print(
        f"load average at the start: {', '.join(f'{x:.1f}' for x in os.getloadavg())}; "
        f"{os.cpu_count()} CPUs"
    )
    per_vote = {}
    with tempfile.TemporaryDirectory() as tmp:
        for participants in args.sizes:
            path = Path(tmp) / f"votes-{participants}.csv"
            start = time.perf_counter()
            n = write_votes(path, participants)
            took = time.perf_counter() - start
            print(
                f"== {participants:,} participants x 10 clips x 6 pairs: {n:,} votes, "
                f"{path.stat().st_size / 1e6:.1f} MB (written in {took:.1f} s)"
            )
            r = compare(path, args.rounds)
            per_vote[participants] = r["wall"] / r["votes"]
    if len(per_vote) > 1:
        small, large = min(per_vote), max(per_vote)
        print(
            f"growth: time per vote at {large:,} participants / at {small:,}: "
            f"{per_vote[large] / per_vote[small]:.2f} (1 = linear in votes)"
        )


if __name__ == "__main__":
    main()
