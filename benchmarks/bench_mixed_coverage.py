"""Coverage of the mixed Bradley-Terry-Davidson model's 95 % intervals, by simulation.

Studies are drawn with known effects (:mod:`app.analysis.mixed_coverage`: scores, side factor,
tie parameter, participant x condition and clip x condition normal effects), every participant
judging every ordered pair of different conditions on every clip once. Each study is fitted by
:func:`app.analysis.mixed_btd.fit_mixed_btd`; the figure is the share of studies whose 95 %
Wald interval holds the true value, pooled over the centred scores theta_i (and per parameter,
with its Monte Carlo standard error). Comparator: the fixed model's Wald intervals on the same
votes, which ignore that votes of one participant or one clip are alike.

Target: coverage of the scores within 92-98 % in every scenario.

Run from the repository root (about 2 minutes on one core with the defaults):

    PYTHONPATH=$PWD python benchmarks/bench_mixed_coverage.py
    PYTHONPATH=$PWD python benchmarks/bench_mixed_coverage.py --studies 200   # quicker
"""

from __future__ import annotations

import argparse
import time

from app.analysis.mixed_coverage import Truth, coverage

SCENARIOS = (
    ("docs study: 4 conditions, 30 participants x 8 clips", Truth(), 30, 8, 1.0),
    ("small: 12 participants x 4 clips", Truth(), 12, 4, 1.0),
    (
        "large effects: sd 1.0 / 0.6",
        Truth(sd_participant=1.0, sd_clip=0.6),
        30,
        8,
        1.0,
    ),
    ("no random variation: sd 0 / 0", Truth(sd_participant=0.0, sd_clip=0.0), 30, 8, 0.5),
    (
        "6 conditions, 20 participants x 4 clips",
        Truth(theta=(-0.6, -0.3, 0.0, 0.1, 0.3, 0.5)),
        20,
        4,
        0.5,
    ),
)
TARGET = (0.92, 0.98)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--studies", type=int, default=1000, help="studies per scenario (x share)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print(
        f"{'scenario':<52} {'studies':>7} {'failed':>6} {'theta':>6} {'log g':>6} "
        f"{'log nu':>6} {'fixed':>6} {'s/fit':>6}  verdict"
    )
    verdicts = []
    for k, (name, truth, participants, clips, share) in enumerate(SCENARIOS):
        studies = max(20, int(args.studies * share))
        start = time.perf_counter()
        r = coverage(
            truth, studies=studies, participants=participants, clips=clips, seed=args.seed + k
        )
        per_fit = (time.perf_counter() - start) / studies
        cov = r["coverage"]
        theta = r["coverage_theta"]
        ok = TARGET[0] <= theta <= TARGET[1]  # type: ignore[operator]
        verdicts.append(ok)
        print(
            f"{name:<52} {studies:7d} {r['failed']:6d} {theta:6.1%} {cov[-2]:6.1%} "  # type: ignore[index]
            f"{cov[-1]:6.1%} {r['fixed_coverage_theta']:6.1%} {per_fit:6.3f}  "  # type: ignore[index]
            + ("met" if ok else "NOT MET")
        )
        print(
            f"{'':<52} mean sd participant {r['mean_sd'][0]:.3f} (truth "  # type: ignore[index]
            f"{truth.sd_participant}), clip {r['mean_sd'][1]:.3f} (truth {truth.sd_clip})"  # type: ignore[index]
        )
    print(
        f"target: coverage of theta within {TARGET[0]:.0%}-{TARGET[1]:.0%}: "
        + ("met in every scenario" if all(verdicts) else "NOT met in every scenario")
    )


if __name__ == "__main__":
    main()
