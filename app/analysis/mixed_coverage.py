"""Coverage of the mixed Bradley-Terry-Davidson model's intervals, by simulation with known effects.

Each simulated study draws participant and clip effects (:mod:`app.analysis.mixed_btd`: one
normal deviation per participant and condition, and per clip and condition), lets every
participant judge every ordered pair of different conditions on every clip once under the
Davidson model with a side effect, fits the model and checks whether each 95 % interval holds
the true value: the centred scores theta_i, log g and log nu. The comparator is the fixed
model's Wald interval on the same votes (the inverse Hessian of the Bradley-Terry-Davidson
likelihood pooled over participants and clips), which treats every vote as independent.

Run: ``PYTHONPATH=$PWD python -m app.analysis.mixed_coverage --studies 200`` (about 5 s per
100 studies of the default size on one core), or ``benchmarks/bench_mixed_coverage.py`` for
the scenarios of docs/reference/analysis.md.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from app.analysis.mixed_btd import fit_mixed_btd
from app.analysis.mixed_btd_model import MIN_VARIANCE, MixedBTDModel


@dataclass(frozen=True)
class Truth:
    """The effects a simulated study is drawn from (theta centred to mean 0 when compared)."""

    theta: tuple[float, ...] = (-0.6, -0.1, 0.2, 0.5)
    gamma: float = 1.2
    nu: float = 0.5
    sd_participant: float = 0.5
    sd_clip: float = 0.3


def simulate_counts(
    truth: Truth, participants: int, clips: int, rng: np.random.Generator
) -> np.ndarray:
    """(P, K, n, n, 3) votes: one per participant, clip and ordered pair of conditions."""
    theta = np.asarray(truth.theta, dtype=float)
    n = theta.size
    worth = (
        theta[None, None]
        + rng.normal(0.0, truth.sd_participant, (participants, 1, n))
        + rng.normal(0.0, truth.sd_clip, (1, clips, n))
    )
    a_i, a_j = worth[:, :, :, None], worth[:, :, None, :]
    eta = np.stack(
        np.broadcast_arrays(np.log(truth.gamma) + a_i, a_j, np.log(truth.nu) + (a_i + a_j) / 2.0),
        axis=-1,
    )
    prob = np.exp(eta - eta.max(axis=-1, keepdims=True))
    prob /= prob.sum(axis=-1, keepdims=True)
    answer = (rng.random(prob.shape[:-1] + (1,)) > np.cumsum(prob, axis=-1)).sum(axis=-1)
    counts = np.eye(3)[np.minimum(answer, 2)]
    counts[:, :, np.arange(n), np.arange(n)] = 0.0
    return counts


def fixed_wald(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """The fixed model's estimates (centred theta, log g, log nu) and Wald standard errors on a
    (P, K, n, n, 3) tensor: the mixed model's Newton iteration with both random effects absent,
    i.e. maximum likelihood of the pooled Bradley-Terry-Davidson model."""
    t = np.array(t, dtype=float)
    n = t.shape[2]
    t[:, :, np.arange(n), np.arange(n)] = 0.0
    model = MixedBTDModel(t)
    var = np.full(2, MIN_VARIANCE)
    z, _, at, ok, _ = model.mode(var, np.zeros(model.m), np.zeros((model.P, n)), tol=1e-9)
    cov = at.s_inv[: model.nf, : model.nf]
    centre = np.eye(n) - 1.0 / n
    se_theta = np.sqrt(np.clip(np.diag(centre @ cov[:n, :n] @ centre), 0.0, None))
    est = np.concatenate([z[:n] - z[:n].mean(), z[n : model.nf]])
    se = np.concatenate([se_theta, np.sqrt(np.diag(cov)[n:])])
    return est, se, ok


def coverage(
    truth: Truth = Truth(),
    *,
    studies: int = 200,
    participants: int = 30,
    clips: int = 8,
    confidence: float = 0.95,
    seed: int = 0,
) -> dict[str, object]:
    """Share of studies whose interval holds the truth, per parameter, with its Monte Carlo
    standard error, the mean estimate and the mean estimated standard deviations; fits that
    failed are counted apart. ``fixed_coverage`` is the same for the fixed model's Wald
    intervals (:func:`fixed_wald`) on the same votes."""
    rng = np.random.default_rng(seed)
    z = float(stats.norm.ppf(0.5 + confidence / 2.0))
    theta = np.asarray(truth.theta) - np.mean(truth.theta)
    names = [f"theta_{q + 1}" for q in range(theta.size)] + ["log_gamma", "log_nu"]
    true = np.concatenate([theta, [np.log(truth.gamma), np.log(truth.nu)]])
    hits, fixed_hits, estimates, sds, failed = [], [], [], [], 0
    for _ in range(studies):
        t = simulate_counts(truth, participants, clips, rng)
        fit = fit_mixed_btd(t)
        f_est, f_se, f_ok = fixed_wald(t)
        if f_ok:
            fixed_hits.append(np.abs(f_est - true) <= z * f_se)
        if not fit.converged:
            failed += 1
            continue
        est = np.concatenate([fit.theta, [np.log(fit.gamma), np.log(fit.nu)]])
        se = np.concatenate([fit.se, [fit.log_gamma_se, fit.log_nu_se]])
        hits.append(np.abs(est - true) <= z * se)
        estimates.append(est)
        sds.append([fit.sd_participant, fit.sd_clip])
    hit = np.asarray(hits, dtype=float)
    fixed_hit = np.asarray(fixed_hits, dtype=float)
    k = theta.size

    def share(h: np.ndarray) -> float:
        return float(h[:, :k].mean()) if len(h) else float("nan")

    return {
        "studies": studies,
        "failed": failed,
        "participants": participants,
        "clips": clips,
        "confidence": confidence,
        "parameters": names,
        "truth": true.tolist(),
        "coverage": hit.mean(axis=0).tolist() if len(hits) else [],
        "coverage_se": (np.sqrt(hit.mean(axis=0) * (1 - hit.mean(axis=0)) / len(hit))).tolist()
        if len(hits)
        else [],
        "coverage_theta": share(hit),
        "fixed_coverage": fixed_hit.mean(axis=0).tolist() if len(fixed_hits) else [],
        "fixed_coverage_theta": share(fixed_hit),
        "mean_estimate": np.mean(estimates, axis=0).tolist() if estimates else [],
        "mean_sd": np.mean(sds, axis=0).tolist() if sds else [],
        "true_sd": [truth.sd_participant, truth.sd_clip],
    }


def _print(result: dict[str, object]) -> None:
    print(
        f"{result['studies']} studies x {result['participants']} participants x "
        f"{result['clips']} clips; {result['failed']} fits failed; "
        f"{result['confidence']:.0%} Wald intervals"
    )
    print(
        f"{'parameter':<10} {'truth':>7} {'mean est.':>9} {'coverage':>8} {'+-MC se':>7} "
        f"{'fixed model':>11}"
    )
    rows = zip(  # type: ignore[call-overload]
        result["parameters"],  # type: ignore[arg-type]
        result["truth"],  # type: ignore[arg-type]
        result["mean_estimate"],  # type: ignore[arg-type]
        result["coverage"],  # type: ignore[arg-type]
        result["coverage_se"],  # type: ignore[arg-type]
        result["fixed_coverage"],  # type: ignore[arg-type]
        strict=True,
    )
    for name, true, est, cov, se, fixed in rows:
        print(f"{name:<10} {true:7.3f} {est:9.3f} {cov:8.1%} {se:7.1%} {fixed:11.1%}")
    print(
        f"all theta  coverage {result['coverage_theta']:.1%} "
        f"(fixed model's Wald intervals {result['fixed_coverage_theta']:.1%})"
    )
    sd, true_sd = result["mean_sd"], result["true_sd"]
    print(
        f"sd participant: mean estimate {sd[0]:.3f} (truth {true_sd[0]}); "  # type: ignore[index]
        f"sd clip: {sd[1]:.3f} (truth {true_sd[1]})"  # type: ignore[index]
    )


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--studies", type=int, default=200)
    parser.add_argument("--participants", type=int, default=30)
    parser.add_argument("--clips", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    _print(
        coverage(
            studies=args.studies, participants=args.participants, clips=args.clips, seed=args.seed
        )
    )


if __name__ == "__main__":
    main()
