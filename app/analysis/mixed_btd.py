"""Bradley-Terry-Davidson with crossed participant and clip random effects.

The fixed model (:mod:`app.analysis.btd`; Davidson 1970, Davidson & Beaver 1977) gives every
vote the same worths. Here participant p and clip k shift each condition's log worth:

    a_pki = theta_i + b_pi + c_ki,   b_pi ~ N(0, sd_participant^2),   c_ki ~ N(0, sd_clip^2)

all independent, and a vote with condition i on the left and j on the right is a multinomial
logit with the Davidson tie and the side effect (lambda = log g, kappa = log nu):

    log P(left) - log P(right)     = lambda + a_pki - a_pkj
    log P(undecided) - log P(right) = kappa + (a_pki + a_pkj) / 2 - a_pkj

Between decided votes this is the logistic mixed model of the preference, logit P(i over j)
= lambda + theta_i - theta_j + (b_pi - b_pj) + (c_ki - c_kj): a participant or clip effect is a
condition-by-participant (-clip) interaction, crossed, the random slopes a reviewer asks for.
Undecided votes are kept as Davidson ties (their own outcome), not split into half wins.

Estimator: penalised quasi-likelihood (PQL; Breslow & Clayton 1993, JASA 88, 9-25, sec. 2,
the Laplace approximation of the marginal likelihood with the random effects at their joint
mode) with REML variances by Schall's update (Schall 1991, Biometrika 78, 719-727):

1. for given variances, the joint mode of fixed and random effects maximises the
   log-likelihood minus the Gaussian penalty sum(b^2) / (2 sd_p^2) + sum(c^2) / (2 sd_c^2) (a
   concave problem: Newton steps with step halving);
2. each variance becomes (sum of its squared modes + trace of its block of H^-1) / number of
   effects, H the Hessian of that penalised objective at the mode over all effects (fixed ones
   included, hence REML-like); between updates the effects take one Newton step towards their
   mode (the working-variate iteration, as ``glmmPQL`` alternates one weighted fit with the
   variances; the mode is found in full at the variances' fixed point); the updates are
   accelerated by SQUAREM (Varadhan & Roland 2008) and a variance below sd 0.02 is taken as 0;
   the updates stop when the distance left to their fixed point, estimated from the rate of
   the last two, is under ``tol``;
3. the covariance of the fixed effects is the fixed block of H^-1 (Wald intervals, normal
   quantile), the scores theta centred to mean 0.

Simulation with known effects (:mod:`app.analysis.mixed_coverage`,
``benchmarks/bench_mixed_coverage.py``) gives 95 % intervals of the scores holding the truth in
92-98 % of studies; docs/reference/analysis.md has the figures.

H is block-diagonal in the participants' effects: every linear solve and log-determinant goes
through the Schur complement of that block, so the cost is linear in participants.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from app.analysis.btd import BOUND, JOD_PER_LOG_WORTH, fit_btd
from app.analysis.json_values import json_number
from app.analysis.mixed_btd_model import MIN_VARIANCE, MixedBTDModel
from app.analysis.mixed_btd_variances import SchallUpdates, moment_variances, settle
from app.analysis.scaling import canonical_participant_order


@dataclass(frozen=True)
class MixedBTDFit:
    """Scores theta (mean 0) with standard errors, side factor gamma, tie parameter nu, the
    random-effect standard deviations and the Laplace objective at the optimum."""

    theta: np.ndarray
    se: np.ndarray
    gamma: float
    log_gamma_se: float
    nu: float
    log_nu_se: float
    sd_participant: float
    sd_clip: float
    votes: int
    converged: bool
    note: str | None = None
    iterations: int = 0  # variance updates
    settled: bool = True  # False: the variance updates reached their cap


#: The model's name as the report's heading and Table 9b give it: the random effects are
#: per participant and per clip on each condition's worth (b_pi, c_ki).
MODEL = "Bradley-Terry-Davidson with participant × condition and clip × condition random effects"
ESTIMATOR = "penalised quasi-likelihood, REML variances (Schall's update); Wald intervals"
#: The most variance updates a fit spends: a few dozen settle every study simulated
#: (benchmarks/bench_analysis.py), one stuck near a bound stops here and says so.
MAX_UPDATES = 300


def fit_mixed_btd(
    t: np.ndarray,
    *,
    max_updates: int = MAX_UPDATES,
    tol: float = 1e-5,
    progress: Callable[[int, int], None] | None = None,
) -> MixedBTDFit:
    """Fit the model to a (P, K, n, n, 3) count tensor (:class:`app.analysis.counts.VoteCounts`):
    penalised quasi-likelihood (Breslow & Clayton 1993) with REML variances by Schall's
    update, alternated with Newton steps to the joint mode until the variances settle.

    ``max_updates`` bounds the variance updates (each a mode found anew: the cost is at most
    that many times one pass over the vote cells); a fit that reaches it keeps the estimates
    at the variances it reached and says so in its note. ``progress(updates, max_updates)``
    is called after each update.

    >>> rng = np.random.default_rng(0)
    >>> t = rng.poisson(3.0, (6, 3, 2, 2, 3)); f = fit_mixed_btd(t); f.converged, f.theta.shape
    (True, (2,))
    """
    # A degenerate design (a single vote, every vote on one side) sends effects to infinity on
    # the way to a fit that is then reported as not converged: its overflows are expected.
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _fit(_own_counts(t), max_updates, tol, progress)


def _own_counts(t: np.ndarray) -> np.ndarray:
    """A copy of the counts for the fit to work on: whole counts as 32-bit integers (a
    quarter of the float64 copies a large study made three of), others as floats."""
    t = np.asarray(t)
    if np.issubdtype(t.dtype, np.integer) and (t.size == 0 or int(np.abs(t).max()) < 2**31):
        return t.astype(np.int32)
    return np.array(t, dtype=float)


def _fit(
    t: np.ndarray,
    max_updates: int,
    tol: float,
    progress: Callable[[int, int], None] | None,
) -> MixedBTDFit:
    """:func:`fit_mixed_btd` itself: the variances by
    :func:`app.analysis.mixed_btd_variances.settle`, then the mode at them and the estimates
    (:func:`_estimates`)."""
    P, K, n = t.shape[:3]
    t[:, :, np.arange(n), np.arange(n)] = 0.0  # same-condition pairs carry no preference
    # Participants in an order of their counts, not of their names: the same votes then give
    # the same fit to the last digit whatever the participants are called. On a flat
    # likelihood (a dozen votes) where the iteration stops depends on the order of the sums,
    # and the clip SD of two orders differed in the fourth digit.
    t = t[canonical_participant_order(t)]
    votes = int(t.sum())
    nan = np.full(n, np.nan)

    def failed(note: str, iterations: int = 0) -> MixedBTDFit:
        return MixedBTDFit(
            nan, nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, votes, False, note, iterations
        )

    if votes == 0 or n < 2:
        return failed("no votes on pairs of different conditions")
    model = MixedBTDModel(t)
    # the effects start at the fixed model's estimates, the variances at moment estimates
    # made from the terms there (:func:`app.analysis.mixed_btd_variances.moment_variances`)
    z, b = _fixed_start(model, t), np.zeros((P, n))
    at_start = model.terms(z, b)
    updates = SchallUpdates(model, z, b, max_updates, progress, t=at_start)
    log_var, settled, left, beyond = settle(updates, tol, moment_variances(model, at_start))
    if beyond is not None:
        return failed(beyond, int(updates.count))
    var = np.exp(log_var)
    iterations = int(updates.count)
    z, b = updates.z, updates.b
    z, b, at, ok, _ = model.mode(var, z, b, updates.t, tol=1e-9)
    if not (ok and updates.ok and np.all(np.isfinite(z)) and np.abs(z[: model.nf]).max() < BOUND):
        return failed("the fit did not converge")
    stopped = None
    if not settled:
        stopped = (
            f"stopped after {iterations} variance updates (the cap) with the log variances "
            f"still about {left:.1g} from their fixed point: the scores are those at the SDs "
            "reached"
        )
    cov = at.s_inv[: model.nf, : model.nf]
    if not np.all(np.diag(cov) >= 0):  # rounding on a nearly flat likelihood: no maximum
        return failed("the fit did not converge")
    return _estimates(model, z, cov, var, votes, stopped, iterations=iterations, settled=settled)


def _fixed_start(model: MixedBTDModel, t: np.ndarray) -> np.ndarray:
    """The dense effects at the fixed model's estimates (scores, log gamma, log nu; the clip
    effects 0), or all 0 when that model has no finite estimate."""
    z = np.zeros(model.m)
    fixed = fit_btd(t.sum(axis=(0, 1)))
    if fixed.converged and fixed.gamma > 0 and (fixed.nu > 0 or not model.ties):
        z[: model.n] = fixed.theta
        z[model.n] = np.log(fixed.gamma)
        if model.ties:
            z[model.n + 1] = np.log(fixed.nu)
    return z


def _estimates(
    model: MixedBTDModel,
    z: np.ndarray,
    cov: np.ndarray,
    var: np.ndarray,
    votes: int,
    stopped: str | None,
    *,
    iterations: int,
    settled: bool,
) -> MixedBTDFit:
    """The fit from the mode ``z`` at the variances ``var`` and the covariance ``cov`` of the
    fixed effects: the scores centred to mean 0 with their standard errors, gamma, nu, the
    SDs and the note (the design's, then ``stopped``)."""
    n = model.n
    centre = np.eye(n) - 1.0 / n
    cov_theta = centre @ cov[:n, :n] @ centre
    notes = {
        (True, True): None,
        (True, False): "one clip: no clip effect",
        (False, True): "one participant: no participant effect",
        (False, False): "one participant and one clip: the fixed model",
    }
    return MixedBTDFit(
        theta=z[:n] - z[:n].mean(),
        se=np.sqrt(np.clip(np.diag(cov_theta), 0.0, None)),
        gamma=float(np.exp(z[n])),
        log_gamma_se=float(np.sqrt(cov[n, n])),
        nu=float(np.exp(z[n + 1])) if model.ties else 0.0,
        log_nu_se=float(np.sqrt(cov[n + 1, n + 1])) if model.ties else np.nan,
        sd_participant=_sd(var[0]) if model.use_p else np.nan,
        sd_clip=_sd(var[1]) if model.use_c else np.nan,
        votes=votes,
        converged=True,
        note="; ".join(x for x in (notes[(model.use_p, model.use_c)], stopped) if x) or None,
        iterations=iterations,
        settled=settled,
    )


def _sd(var: float) -> float:
    return 0.0 if var <= MIN_VARIANCE else float(np.sqrt(var))


def mixed_btd_summary(
    t: np.ndarray,
    names: Sequence[str],
    confidence: float = 0.95,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """The model as JSON for a (P, K, n, n, 3) tensor: scores (log worth, mean 0) with Wald
    intervals and in JOD, gamma and nu with intervals (Wald on the log scale), the standard
    deviations of the participant and clip effects. Conditions never compared get null."""
    t = np.asarray(t)
    t = t if np.issubdtype(t.dtype, np.integer) else t.astype(float)
    # participants, clips and conditions with votes (copies only where some have none: the
    # tensor of a large study is hundreds of megabytes)
    seen = t.reshape(t.shape[0], -1).sum(axis=1) > 0
    t = t if seen.all() else t[seen]
    by_clip = t.sum(axis=0)
    seen = by_clip.reshape(by_clip.shape[0], -1).sum(axis=1) > 0
    t = t if seen.all() else t[:, seen]
    n = len(names)
    off = ~np.eye(n, dtype=bool)
    pair = np.where(off, by_clip[seen].sum(axis=(0, 3)), 0.0)
    active = np.flatnonzero((pair + pair.T).sum(axis=1) > 0)
    sub = t if active.size == n else t[:, :, active][:, :, :, active]
    fixed = fit_btd(sub.sum(axis=(0, 1))) if active.size >= 2 else None
    fit = (
        fit_mixed_btd(sub, progress=progress)
        if fixed is not None and fixed.converged
        else MixedBTDFit(
            np.zeros(0),
            np.zeros(0),
            np.nan,
            np.nan,
            np.nan,
            np.nan,
            np.nan,
            np.nan,
            int(sub.sum()),
            False,
            "no finite estimate, as for the fixed model: " + str(fixed.note),
        )
        if fixed is not None
        else MixedBTDFit(
            np.zeros(0),
            np.zeros(0),
            np.nan,
            np.nan,
            np.nan,
            np.nan,
            np.nan,
            np.nan,
            0,
            False,
            "fewer than two conditions were compared",
        )
    )
    zq = float(stats.norm.ppf(0.5 + confidence / 2.0))
    scores: dict[str, Any] = {c: None for c in names}
    ci: dict[str, Any] = {c: [None, None] for c in names}
    se: dict[str, Any] = {c: None for c in names}
    if fit.converged:
        for q, c in enumerate(active.tolist()):
            scores[names[c]] = json_number(fit.theta[q])
            se[names[c]] = json_number(fit.se[q])
            ci[names[c]] = [
                json_number(fit.theta[q] - zq * fit.se[q]),
                json_number(fit.theta[q] + zq * fit.se[q]),
            ]

    def interval(value: float, log_se: float) -> list[Any]:
        if not (fit.converged and value > 0):
            return [None, None]
        with np.errstate(over="ignore"):  # an unbounded side is reported as None
            return [
                json_number(value * np.exp(-zq * log_se)),
                json_number(value * np.exp(zq * log_se)),
            ]

    return {
        "model": MODEL,
        "estimator": ESTIMATOR,
        "scores": scores,
        "se": se,
        "ci": ci,
        "jod": {c: None if v is None else v * JOD_PER_LOG_WORTH for c, v in scores.items()},
        "jod_ci": {
            c: [None if v is None else v * JOD_PER_LOG_WORTH for v in iv] for c, iv in ci.items()
        },
        "gamma": json_number(fit.gamma) if fit.converged else None,
        "gamma_ci": interval(fit.gamma, fit.log_gamma_se),
        "nu": json_number(fit.nu) if fit.converged else None,
        "nu_ci": interval(fit.nu, fit.log_nu_se),
        "sd_participant": json_number(fit.sd_participant) if fit.converged else None,
        "sd_clip": json_number(fit.sd_clip) if fit.converged else None,
        "n": fit.votes,
        "participants": int(t.shape[0]),
        "clips": int(t.shape[1]),
        "iterations": fit.iterations,
        "settled": fit.settled,
        "note": fit.note,
    }
