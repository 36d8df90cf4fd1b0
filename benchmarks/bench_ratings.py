"""Benchmark: ``facepair analyze ratings.csv`` (the MOS mixed model) against ``lme4::lmer``.

Writes a simulated rating study as the web app exports it (``ratings.csv``: participants x 10
clips x 4 conditions, ACR scores 1-5 from known effects: condition means 2.4-3.6, participant
sd 0.6, clip sd 0.3, residual sd 0.8), then runs in alternating rounds, each in a fresh
child process, on the same file:

- comparator: R, ``read.csv`` and ``lmer(score ~ 0 + condition + (1 | participant) +
  (1 | clip), REML = TRUE)`` (package loading excluded);
- facepair: ``read_ratings`` and ``analyze_ratings`` (imports excluded): the checks of the
  file, the mixed model, the raw MOS, the Holm contrasts.

Printed per size: the medians of wall and CPU time, the CPU ratio facepair / lme4 per round
(targets: at most 2 at 1,000 and 10,000 participants), the largest difference of the
estimates (condition means, their standard errors, the three SDs; target 1e-4) and
facepair's peak resident memory above its imports against the CSV's size (target 10x).

Run from the repository root (R and lme4 from Debian: r-base-core, r-cran-lme4):

    PYTHONPATH=$PWD python benchmarks/bench_ratings.py                 # 100, 1,000, 10,000
    PYTHONPATH=$PWD python benchmarks/bench_ratings.py --sizes 1000 --rounds 5
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
CONDITIONS = ("none", "random", "speech_driven", "ground_truth")
MEANS = (2.4, 2.9, 3.3, 3.6)

_CHILD_FACEPAIR = """
import json, sys, time
def peak_kb():
    with open("/proc/self/status") as status:
        return next(int(l.split()[1]) for l in status if l.startswith("VmHWM"))
from app.analysis.rating_results import analyze_ratings, read_ratings
import app.analysis.crossed_lmm, scipy.optimize, scipy.sparse, scipy.linalg  # imported on use
base = peak_kb()
start, cpu = time.perf_counter(), time.process_time()
result = analyze_ratings(read_ratings(sys.argv[1]))
wall, cpu = time.perf_counter() - start, time.process_time() - cpu
mos = result["mos"]
z = 1.959963984540054
print(json.dumps({
    "wall": wall, "cpu": cpu, "peak_kb": peak_kb(), "base_kb": base,
    "beta": [mos["mos"][c] for c in mos["conditions"]],
    "se": [(mos["ci"][c][1] - mos["ci"][c][0]) / (2 * z) for c in mos["conditions"]],
    "sd": [mos["sd_participant"], mos["sd_clip"], mos["sd_residual"]],
}))
"""

_CHILD_R = r"""
suppressMessages(library(lme4))
peak_kb <- function() {
  s <- readLines("/proc/self/status")
  as.numeric(gsub("[^0-9]", "", s[grepl("^VmHWM", s)]))
}
base <- peak_kb()
t0 <- proc.time()
d <- read.csv(commandArgs(TRUE)[1])
d$condition <- factor(d$condition, levels = sort(unique(d$condition)))
m <- lmer(score ~ 0 + condition + (1 | participant) + (1 | clip), data = d, REML = TRUE)
vc <- as.data.frame(VarCorr(m))
est <- c(fixef(m), sqrt(diag(as.matrix(vcov(m)))))
sds <- c(vc$sdcor[vc$grp == "participant"], vc$sdcor[vc$grp == "clip"], sigma(m))
t1 <- proc.time() - t0
f <- function(x) paste(format(x, digits = 17), collapse = ", ")
cat(sprintf(paste0('{"wall": %s, "cpu": %s, "peak_kb": %s, "base_kb": %s, ',
                 '"beta": [%s], "se": [%s], "sd": [%s]}\n'),
    t1[["elapsed"]], t1[["user.self"]] + t1[["sys.self"]], peak_kb(), base,
    f(est[1:4]), f(est[5:8]), f(sds)))
"""


def write_ratings(path: Path, participants: int, seed: int = 1) -> int:
    """The simulated study as ``ratings.csv``; returns the number of ratings."""
    from app.analysis.rating_results import write_ratings_csv

    rng = np.random.default_rng(seed)
    clips = 10
    p, k, c = (
        a.ravel()
        for a in np.meshgrid(
            np.arange(participants), np.arange(clips), np.arange(len(CONDITIONS)), indexing="ij"
        )
    )
    y = np.asarray(MEANS)[c] + rng.normal(0, 0.6, participants)[p] + rng.normal(0, 0.3, clips)[k]
    score = np.clip(np.rint(y + rng.normal(0, 0.8, len(p))), 1, 5).astype(int)
    rows = (
        {
            "participant": f"P{pi:05d}",
            "clip": f"s{ki}",
            "condition": CONDITIONS[ci],
            "score": int(si),
            "scale": "acr5",
            "trial": int(ki * len(CONDITIONS) + ci),
            "kind": "trial",
            "status": "finished",
            "study": "benchmark",
        }
        for pi, ki, ci, si in zip(p.tolist(), k.tolist(), c.tolist(), score.tolist(), strict=True)
    )
    write_ratings_csv(list(rows), path)
    return len(p)


def _run(command: list[str]) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    out = subprocess.run(command, capture_output=True, text=True, env=env, cwd=REPO)
    if out.returncode != 0:
        sys.exit(f"{Path(command[0]).name} failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def compare(path: Path, rounds: int, rscript: str) -> None:
    size = path.stat().st_size
    facepair = [sys.executable, "-c", _CHILD_FACEPAIR, str(path)]
    script = path.with_suffix(".R")
    script.write_text(_CHILD_R)
    lme4 = [rscript, "--vanilla", str(script), str(path)]
    _run(facepair), _run(lme4)  # warm the page cache
    ours, theirs = [], []
    for k in range(rounds):
        for name, command, into in (("lme4", lme4, theirs), ("facepair", facepair, ours)):
            r = _run(command)
            into.append(r)
            print(
                f"  round {k + 1} {name:<8} {r['wall']:7.2f} s (CPU {r['cpu']:.2f} s), "
                f"peak {r['peak_kb'] / 1024:6.0f} MB (before the file {r['base_kb'] / 1024:.0f} MB)"
            )
    ratios = [o["cpu"] / t["cpu"] for o, t in zip(ours, theirs, strict=True)]
    walls = [o["wall"] / t["wall"] for o, t in zip(ours, theirs, strict=True)]
    diff = max(
        float(np.max(np.abs(np.asarray(ours[0][key]) - np.asarray(theirs[0][key]))))
        for key in ("beta", "se", "sd")
    )
    above = max(r["peak_kb"] - r["base_kb"] for r in ours) * 1024
    print(
        f"lme4     median {statistics.median(r['wall'] for r in theirs):7.2f} s wall, "
        f"{statistics.median(r['cpu'] for r in theirs):.2f} s CPU"
    )
    print(
        f"facepair median {statistics.median(r['wall'] for r in ours):7.2f} s wall, "
        f"{statistics.median(r['cpu'] for r in ours):.2f} s CPU"
    )
    print(
        f"CPU ratio facepair / lme4: {statistics.median(ratios):.2f} (median); per round "
        + ", ".join(f"{x:.2f}" for x in ratios)
        + f"; wall ratio {statistics.median(walls):.2f}"
    )
    print(f"largest difference of the estimates (means, SEs, SDs): {diff:.1e} (target 1e-4)")
    print(
        f"facepair peak RSS above its imports {above / 1e6:.0f} MB = {above / size:.1f}x the "
        f"CSV ({size / 1e6:.2f} MB; target 10x); whole process "
        f"{max(r['peak_kb'] for r in ours) * 1024 / 1e6:.0f} MB"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 10000])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    rscript = shutil.which("Rscript")
    if rscript is None:
        sys.exit("Rscript not found: apt-get install r-base-core r-cran-lme4")
    print(f"load average at the start: {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    with tempfile.TemporaryDirectory() as tmp:
        for participants in args.sizes:
            path = Path(tmp) / f"ratings-{participants}.csv"
            start = time.perf_counter()
            n = write_ratings(path, participants)
            took = time.perf_counter() - start
            print(
                f"== {participants:,} participants x 10 clips x 4 conditions: {n:,} ratings, "
                f"{path.stat().st_size / 1e6:.2f} MB (written in {took:.1f} s)"
            )
            compare(path, args.rounds, rscript)


if __name__ == "__main__":
    main()
