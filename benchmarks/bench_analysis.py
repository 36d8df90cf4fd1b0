"""Benchmark: ``facepair analyze`` without bootstrap against pandas' bare read of the same file.

Writes a simulated votes CSV (participants x 10 clips x 16 ordered pairs of 4 conditions, the
export's 23 columns, through ``write_votes_csv``), then runs in alternating rounds, each in a
fresh child process:

- comparator: ``pandas.read_csv(path)`` with its defaults, nothing else;
- facepair: ``read_votes(path)`` and ``analyze(table, bootstrap=0, mixed_model=False)``, every
  statistic but the mixed model (``--mixed`` adds one run with it, timed on its own line).

Each child reports its wall time (imports excluded) and its peak resident memory (the
kernel's high-water mark ``VmHWM`` of the process, imports included, and the imports alone).
Printed: per side the median over rounds, the ratio facepair / comparator and peak memory
over the CSV's size. Targets: within 4x the bare read, peak memory <= 3x the CSV.

Run from the repository root:

    PYTHONPATH=$PWD python benchmarks/bench_analysis.py            # 1,000 participants, ~1 min
    PYTHONPATH=$PWD python benchmarks/bench_analysis.py --full     # 10,000: 1.6 M votes
    PYTHONPATH=$PWD python benchmarks/bench_analysis.py --extras   # also bootstrap, report, plan
    PYTHONPATH=$PWD python benchmarks/bench_analysis.py --mixed    # and the mixed model once
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

TRUTH = {"none": -0.8, "random": 0.1, "speech_driven": 0.35, "ground_truth": 0.6}
REPO = Path(__file__).resolve().parent.parent

# Peak resident memory in kB: the kernel's high-water mark of this process image (VmHWM);
# ru_maxrss would carry the benchmark's own peak over the exec when it wrote the file.
_PEAK = """
def peak_kb():
    try:
        with open("/proc/self/status") as status:
            return next(int(l.split()[1]) for l in status if l.startswith("VmHWM"))
    except OSError:
        import resource
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
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
peak = peak_kb()
print(json.dumps({"wall": wall, "cpu": cpu, "rows": len(frame), "peak_kb": peak, "base_kb": base}))
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
results = analyze(table, bootstrap=0, mixed_model=sys.argv[2] == "mixed")
wall, cpu = time.perf_counter() - start, time.process_time() - cpu
peak = peak_kb()
print(json.dumps({"wall": wall, "cpu": cpu, "read": read, "rows": results["input"]["votes"],
                  "peak_kb": peak, "base_kb": base}))
"""
)


def _child(code: str, path: Path, *args: str) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    out = subprocess.run(
        [sys.executable, "-c", code, str(path), *args],
        check=True,
        capture_output=True,
        text=True,
        env=env,
        cwd=REPO,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def write_votes(path: Path, participants: int) -> int:
    """The simulated study as the export writes it; returns the number of votes."""
    from app.analysis import write_votes_csv
    from app.analysis.simulate import simulate_votes

    clips = [f"s{k}" for k in range(10)]
    votes = simulate_votes(TRUTH, participants=participants, clips=clips, seed=1)
    return write_votes_csv(votes, path)


def compare(path: Path, rounds: int, mixed: bool) -> None:
    """Alternating rounds of the comparator and facepair; prints medians, ratio and memory.
    A first round of each warms the page cache and is not counted."""
    size = path.stat().st_size
    _child(_CHILD_PANDAS, path), _child(_CHILD_FACEPAIR, path, "plain")
    bare, ours = [], []
    for k in range(rounds):
        for name, code, into in (
            ("pandas", _CHILD_PANDAS, bare),
            ("facepair", _CHILD_FACEPAIR, ours),
        ):
            r = _child(code, path, "plain")
            into.append(r)
            extra = f", read {r['read']:.2f} s" if "read" in r else ""
            print(
                f"  round {k + 1} {name:<8} {r['wall']:6.2f} s (CPU {r['cpu']:.2f} s){extra}, "
                f"peak {r['peak_kb'] / 1024:6.0f} MB"
            )
    t_bare = statistics.median(r["wall"] for r in bare)
    t_ours = statistics.median(r["wall"] for r in ours)
    t_read = statistics.median(r["read"] for r in ours)
    ratios = [o["wall"] / b["wall"] for b, o in zip(bare, ours, strict=True)]
    cpu_ratios = [o["cpu"] / b["cpu"] for b, o in zip(bare, ours, strict=True)]
    peak_bare = max(r["peak_kb"] for r in bare) * 1024
    peak_ours = max(r["peak_kb"] for r in ours) * 1024
    base_ours = min(r["base_kb"] for r in ours) * 1024
    print(
        f"CSV: {size / 1e6:.1f} MB, {ours[0]['rows']:,} votes; {rounds} alternating rounds "
        "after one warm-up round each"
    )
    print(f"comparator  pandas.read_csv(path)  {t_bare:6.2f} s  (median)")
    print(
        f"facepair    read_votes + analyze(bootstrap=0, mixed_model=False)  {t_ours:6.2f} s  "
        f"(median; reading {t_read:.2f} s)"
    )
    print(
        f"ratio facepair / comparator: {t_ours / t_bare:.2f} (of the medians); per round "
        + ", ".join(f"{x:.2f}" for x in ratios)
        + "  (target <= 4)"
    )
    print(
        "ratio of CPU time (less moved by other work on a shared host): "
        f"{statistics.median(cpu_ratios):.2f} (median of rounds); per round "
        + ", ".join(f"{x:.2f}" for x in cpu_ratios)
    )
    print(f"load average at the end: {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print(
        f"peak RSS facepair {peak_ours / 1e6:.0f} MB = {peak_ours / size:.2f}x the CSV "
        f"(imports alone {base_ours / 1e6:.0f} MB; target <= 3x); "
        f"comparator {peak_bare / 1e6:.0f} MB = {peak_bare / size:.2f}x"
    )
    if mixed:
        r = _child(_CHILD_FACEPAIR, path, "mixed")
        print(
            f"with the mixed model (one run): {r['wall']:.2f} s = {r['wall'] / t_bare:.2f}x the "
            f"comparator's median, the model alone {r['wall'] - t_ours:.2f} s more; peak RSS "
            f"{r['peak_kb'] * 1024 / 1e6:.0f} MB = {r['peak_kb'] * 1024 / size:.2f}x the CSV"
        )


def _best(fn, repeat: int = 3) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def extras(path: Path, tmp: Path) -> None:
    """Bootstrap statistics, the report and the planner on the same votes (in this process)."""
    from app.analysis import analyze, read_votes
    from app.analysis.plan import StudyPlan, plan_study
    from app.analysis.report.writer import write_report

    table = read_votes(path)
    t_stats, results = _best(lambda: analyze(table, conditions=list(TRUTH)))
    t_html, _ = _best(lambda: write_report(results, tmp / "r.html"))
    t_both, _ = _best(lambda: write_report(results, tmp / "r.html", tmp / "r.pdf"))
    print(
        f"statistics (analyze)   {t_stats:6.2f} s  (best of 3; target < 10 s; "
        f"bootstrap {results['options']['bootstrap']} replicates per clip and pooled)"
    )
    print(
        f"report HTML            {t_html:6.2f} s  ({(tmp / 'r.html').stat().st_size / 1e6:.1f} MB)"
    )
    print(f"report HTML + PDF      {t_both:6.2f} s  (target < 5 s)")
    plan = StudyPlan(tuple(TRUTH), tuple(TRUTH.values()))
    t_plan, _ = _best(lambda: plan_study(plan, [50], simulations=1000))
    print(f"plan, 1,000 x 50 part. {t_plan:6.2f} s  (best of 3; target < 10 s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--participants", type=int, default=1000)
    parser.add_argument("--full", action="store_true", help="10,000 participants (1.6 M votes)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--votes", type=Path, help="reuse (or keep) the votes CSV at this path")
    parser.add_argument("--extras", action="store_true", help="bootstrap, report and plan too")
    parser.add_argument(
        "--mixed", action="store_true", help="also one run with the mixed model (mixed_btd)"
    )
    args = parser.parse_args()
    participants = 10000 if args.full else args.participants
    with tempfile.TemporaryDirectory() as tmp:
        path = args.votes or Path(tmp) / "votes.csv"
        if not path.exists():
            start = time.perf_counter()
            n = write_votes(path, participants)
            print(
                f"wrote {n:,} votes ({participants:,} participants x 10 clips x 16 ordered "
                f"pairs) in {time.perf_counter() - start:.1f} s"
            )
        compare(path, args.rounds, args.mixed)
        if args.extras:
            extras(path, Path(tmp))


if __name__ == "__main__":
    main()
