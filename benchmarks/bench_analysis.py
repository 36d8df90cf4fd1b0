"""Benchmark: 1,000 participants x 10 clips x 16 ordered pairs (160,000 votes).

Prints the time to read and validate the votes CSV, to compute every statistic (targets:
statistics < 1 s without bootstrap, < 10 s with 1,000 resamples, report < 5 s), to write the
HTML and PDF report, and to plan a study (1,000 simulations x 4 conditions x 50 participants,
target < 10 s). Run from the repository root: ``python benchmarks/bench_analysis.py``.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from app.analysis import analyze, read_votes, write_votes_csv
from app.analysis.plan import StudyPlan, plan_study
from app.analysis.report import write_report
from app.analysis.simulate import simulate_votes

TRUTH = {"none": -0.8, "random": 0.1, "speech_driven": 0.35, "ground_truth": 0.6}


def _best(fn, repeat: int = 3) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def main() -> None:
    votes = simulate_votes(TRUTH, participants=1000, clips=[f"s{k}" for k in range(10)], seed=1)
    with tempfile.TemporaryDirectory() as tmp:
        csv_path = Path(tmp) / "votes.csv"
        t_write, _ = _best(lambda: write_votes_csv(votes, csv_path), 1)
        t_read, table = _best(lambda: read_votes(csv_path))
        t_plain, _ = _best(lambda: analyze(table, conditions=list(TRUTH), bootstrap=0))
        t_stats, results = _best(lambda: analyze(table, conditions=list(TRUTH)))
        t_html, _ = _best(lambda: write_report(results, Path(tmp) / "r.html"))
        t_both, _ = _best(lambda: write_report(results, Path(tmp) / "r.html", Path(tmp) / "r.pdf"))
        size_html = (Path(tmp) / "r.html").stat().st_size / 1e6
        size_pdf = (Path(tmp) / "r.pdf").stat().st_size / 1e6
    print(f"votes: {len(votes):,} (1,000 participants x 10 clips x 16 ordered pairs)")
    print(f"write votes CSV        {t_write:6.2f} s")
    print(f"read + validate CSV    {t_read:6.2f} s  (best of 3)")
    print(f"statistics, no boot.   {t_plain:6.2f} s  (best of 3; target < 1 s)")
    print(
        f"statistics (analyze)   {t_stats:6.2f} s  (best of 3; target < 10 s; "
        f"bootstrap {results['options']['bootstrap']} replicates per clip and pooled)"
    )
    print(f"report HTML            {t_html:6.2f} s  ({size_html:.1f} MB)")
    print(f"report HTML + PDF      {t_both:6.2f} s  (target < 5 s; PDF {size_pdf:.1f} MB)")
    plan = StudyPlan(tuple(TRUTH), tuple(TRUTH.values()))
    t_plan, _ = _best(lambda: plan_study(plan, [50], simulations=1000))
    print(f"plan, 1,000 x 50 part. {t_plan:6.2f} s  (best of 3; target < 10 s)")


if __name__ == "__main__":
    main()
