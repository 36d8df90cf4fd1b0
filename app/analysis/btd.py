"""Bradley-Terry-Davidson model with a side (order) effect, fitted by maximum likelihood.

Davidson (1970, JASA 65, 317-328) extends the Bradley-Terry model to ties; Davidson & Beaver
(1977, Biometrics 33, 693-702) add an order effect. With condition i on the left panel and j on
the right, worths pi > 0, a side factor g (the left item's worth is multiplied by g) and a tie
parameter nu >= 0:

    P(left i chosen)  = g pi_i / D
    P(right j chosen) = pi_j / D
    P(undecided)      = nu sqrt(pi_i pi_j) / D,     D = g pi_i + pi_j + nu sqrt(pi_i pi_j)

In logs (theta = log pi, lambda = log g, kappa = log nu) each cell is a multinomial logit with
linear predictors (lambda + theta_i, theta_j, kappa + (theta_i + theta_j) / 2), so the
log-likelihood is concave; it is maximised with scipy.optimize (trust-region Newton with the
exact gradient and Hessian), the scores theta centred to mean 0. Identical-clip pairs (the same
condition on both sides) carry no preference and are left out of the fit; without any
undecided vote nu is 0 and the model is Bradley-Terry with an order effect. A maximum may not
exist (a condition that wins or loses every comparison, a design whose pairs do not link all
conditions): the fit then reports no scores and says why.

Confidence intervals: percentile bootstrap over participants, every replicate refitted at once
by a batched Newton iteration on the same likelihood.

JOD (pwcmp's unit; Perez-Ortiz & Mantiuk 2017): 1 JOD is the difference that 75 % of decided
votes prefer; between decided votes the model is logistic in theta_i - theta_j, so
JOD = theta / ln 3.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import optimize

from app.analysis.btd_likelihood import batched_terms, design_matrix, vote_cells
from app.analysis.counts import with_votes
from app.analysis.json_values import json_number
from app.analysis.scaling import canonical_participant_order, connected, resampled_sums
from app.analysis.signtest import sign_test_p

JOD_PER_LOG_WORTH = float(1.0 / np.log(3.0))
BOUND = 15.0  # |theta|, |log g|, |log nu| beyond this: the maximum is at infinity
TOLERANCE = 1e-8


def log_likelihood(counts: np.ndarray, theta: np.ndarray, gamma: float, nu: float) -> float:
    """Log-likelihood of an (n, n, 3) count array (left, right, undecided) under the model."""
    ties = nu > 0
    beta = np.concatenate([theta, [np.log(gamma)], [np.log(nu)] if ties else []])[None]
    x = design_matrix(len(theta), ties).reshape(-1, 2 + ties, len(beta[0]))
    off = ~np.eye(len(theta), dtype=bool)
    if not ties and counts[off][:, 2].sum() > 0:
        return float("-inf")
    nll, _, _ = batched_terms(beta, vote_cells(counts[None], ties), x[off.ravel()], penalty=False)
    return float(-nll[0])


@dataclass(frozen=True)
class BTDFit:
    """One fit: scores theta (mean 0), gamma, nu, the log-likelihood and the votes used."""

    theta: np.ndarray
    gamma: float
    nu: float
    loglik: float
    votes: int
    converged: bool
    note: str | None = None


def _setup(counts: np.ndarray) -> tuple[bool, np.ndarray]:
    n = counts.shape[-2]
    off = ~np.eye(n, dtype=bool)
    ties = bool(counts[..., off, 2].sum() > 0)
    return ties, design_matrix(n, ties)[off]


def _finite(beta: np.ndarray, ties: bool) -> np.ndarray:
    """A maximum inside the bounds: every parameter, and the spread of the scores (with a
    condition that wins every comparison the scores part without end while their mean stays
    0, so each alone can look bounded)."""
    n = beta.shape[-1] - 1 - int(ties)
    spread = np.ptp(beta[..., :n], axis=-1) if n else np.zeros(beta.shape[:-1])
    return (
        np.all(np.isfinite(beta), axis=-1) & (np.abs(beta).max(axis=-1) < BOUND) & (spread < BOUND)
    )


def fit_btd(counts: np.ndarray, *, side: bool = True) -> BTDFit:
    """Maximum-likelihood fit of an (n, n, 3) count array: [left, right] cell = votes with
    condition ``left`` on the left panel, answers left / right / undecided.

    ``side=False`` fixes g at 1 (Davidson's model without the order effect, as psychotools'
    ``btmodel`` fits it): for data whose sides carry no information, or a comparison with it.

    >>> c = np.zeros((2, 2, 3)); c[0, 1] = [8, 1, 2]; c[1, 0] = [2, 4, 2]  # pi = (4, 1), g 2
    >>> f = fit_btd(c); np.round(f.theta, 6).tolist(), round(f.gamma, 6), round(f.nu, 6)
    ([0.693147, -0.693147], 2.0, 1.0)
    """
    counts = np.asarray(counts, dtype=float)
    n = counts.shape[-2]
    off = ~np.eye(n, dtype=bool)
    votes = int(counts[off].sum())
    nan = np.full(n, np.nan)
    decided = counts[..., 0] + np.swapaxes(counts[..., 1], 0, 1) + counts[..., 2]
    if votes == 0 or not connected(np.where(off, decided, 0.0)):
        return BTDFit(
            nan,
            np.nan,
            np.nan,
            np.nan,
            votes,
            False,
            "the compared pairs do not link all conditions",
        )
    ties, x = _setup(counts)
    cells = vote_cells(counts[None], ties)
    if not side:
        # lambda leaves the likelihood; the penalty lambda^2 / 2 holds it at 0 exactly
        x = x.copy()
        x[..., n] = 0.0
    hold = np.zeros(x.shape[-1])
    hold[n] = 0.0 if side else 1.0

    def objective(beta: np.ndarray) -> tuple[float, np.ndarray]:
        nll, grad, _ = batched_terms(beta[None], cells, x)
        return float(nll[0]) + 0.5 * float(hold @ beta**2), grad[0] + hold * beta

    def hessian(beta: np.ndarray) -> np.ndarray:
        return batched_terms(beta[None], cells, x)[2][0] + np.diag(hold)

    res = optimize.minimize(
        objective,
        np.zeros(x.shape[-1]),
        jac=True,
        hess=hessian,
        method="trust-exact",
        options={"gtol": 1e-10, "maxiter": 300},
    )
    beta = res.x
    # trust-exact may stop short of its gtol on rounding ("failure to predict improvement")
    # with the maximum found; judge the result by its gradient, relative to the votes.
    stationary = np.abs(objective(beta)[1]).max() < 1e-7 * max(1.0, votes)
    ok = bool(stationary) and bool(_finite(beta[None], ties)[0])
    if not ok:
        return BTDFit(
            nan,
            np.nan,
            np.nan,
            np.nan,
            votes,
            False,
            "no finite maximum-likelihood estimate (a condition won or lost every "
            "comparison, or every decided vote went to one side)",
        )
    theta = beta[:n] - beta[:n].mean()
    nu = float(np.exp(beta[n + 1])) if ties else 0.0
    gamma = float(np.exp(beta[n]))
    return BTDFit(theta, gamma, nu, log_likelihood(counts, theta, gamma, nu), votes, True)


def fit_btd_many(
    counts: np.ndarray, *, max_iter: int = 60, start: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Fit every (n, n, 3) array of ``counts`` (B, n, n, 3) at once by damped Newton steps.

    Returns (beta (B, k), converged (B,)); beta = theta_1..theta_n, log g[, log nu] where the
    ties term is present when any array holds an undecided vote off the diagonal. ``start``
    (k,) is where every fit begins (default 0); a nearby start saves iterations.
    """
    counts = np.asarray(counts, dtype=float)
    ties, x = _setup(counts)
    cells = vote_cells(counts, ties)
    b, k = counts.shape[0], x.shape[-1]
    beta = np.zeros((b, k)) if start is None or len(start) != k else np.tile(start, (b, 1))
    nll, grad, hess = batched_terms(beta, cells, x)
    done = np.zeros(b, dtype=bool)
    ridge = 1e-10 * np.eye(k)
    for _ in range(max_iter):
        step = -np.linalg.solve(hess + ridge, grad[..., None])[..., 0]
        step[done] = 0.0
        # a full step under the tolerance is not taken: the fit is there (one evaluation of
        # every refit fewer)
        done |= np.abs(step).max(axis=1) < TOLERANCE
        if done.all():
            break
        step[done] = 0.0
        scale = np.ones(b)
        for _half in range(30):
            trial = beta + scale[:, None] * step
            new = batched_terms(trial, cells, x)
            # rounding of sums over many votes: a step is worse only beyond its precision
            worse = ~(new[0] <= nll + 1e-10 * np.maximum(1.0, np.abs(nll))) & ~done
            if not worse.any():
                break
            scale = np.where(worse, scale / 2.0, scale)
        beta, (nll, grad, hess) = trial, new
        done |= np.abs(scale[:, None] * step).max(axis=1) < TOLERANCE
        if done.all():
            break
    n = counts.shape[-2]
    beta[:, :n] -= beta[:, :n].mean(axis=1, keepdims=True)
    return beta, done & _finite(beta, ties)


def bootstrap_btd(
    per_participant: np.ndarray,
    replicates: int,
    seed: int,
    confidence: float,
    resampled: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """Percentile intervals (k, 2) of (theta..., g, nu) and the replicates that converged.

    ``per_participant`` is (P, n, n, 3), resampled as
    :func:`app.analysis.scaling.bootstrap_weights` draws, or ``resampled`` (replicates, n, n,
    3): those sums made already. Too few converged replicates: NaN.
    """
    p, n = per_participant.shape[0], per_participant.shape[-2]
    boot = (
        resampled_sums(per_participant.reshape(p, -1), replicates, seed).reshape(-1, n, n, 3)
        if resampled is None
        else resampled
    )
    beta, ok = fit_btd_many(boot)
    values = np.column_stack([beta[:, :n], np.exp(beta[:, n:])])
    if values.shape[1] == n + 1:
        values = np.column_stack([values, np.zeros(len(values))])
    if ok.sum() < max(10, len(ok) // 2):
        return np.full((n + 2, 2), np.nan), int(ok.sum())
    tail = (1.0 - confidence) / 2.0 * 100.0
    return np.percentile(values[ok], [tail, 100.0 - tail], axis=0).T, int(ok.sum())


def leave_one_out_loglik(per_participant: np.ndarray) -> np.ndarray:
    """Each participant's log-likelihood under the model fitted to everyone else (pwcmp's
    outlier analysis, with this model in place of Case V); NaN where that fit has no maximum."""
    p = per_participant.shape[0]
    total = per_participant.sum(axis=0)
    rest = total[None] - per_participant
    whole, whole_ok = fit_btd_many(total[None])
    beta, ok = fit_btd_many(rest, start=whole[0] if whole_ok[0] else None)
    ties, x = _setup(rest)
    nll, _, _ = batched_terms(beta, vote_cells(per_participant, ties), x, penalty=False)
    own = per_participant[..., ~np.eye(per_participant.shape[-2], dtype=bool), 2].sum(axis=-1)
    impossible = (~np.full(p, ties)) & (own > 0)
    return np.where(ok & ~impossible, -nll, np.nan)


def side_check(t: np.ndarray) -> dict[str, float | int | None]:
    """Votes on identical-clip pairs (the same condition on both sides): a side-bias check.

    Either answer but "undecided" is a guess, so left and right should be equally common:
    exact two-sided binomial test of left against right.
    """
    n = t.shape[-2]
    same = t[..., np.arange(n), np.arange(n), :].reshape(-1, 3).sum(axis=0)
    left, right, und = (int(v) for v in same)
    return {
        "votes": left + right + und,
        "left": left,
        "right": right,
        "undecided": und,
        "share_left": json_number(left / (left + right)) if left + right else None,
        "p": json_number(sign_test_p(left, right)) if left + right else None,
    }


def btd_summary(
    t: np.ndarray,
    names: Sequence[str],
    *,
    bootstrap: int = 1000,
    seed: int = 0,
    confidence: float = 0.95,
    resampled: np.ndarray | None = None,
) -> dict[str, Any]:
    """The model for one clip (or pooled) as JSON: scores (log worth, mean 0), nu, gamma,
    percentile intervals over participants, the log-likelihood, votes, JOD and the check of
    identical pairs. ``t`` is (P, n, n, 3). Conditions without any vote get null.
    ``resampled``: the resampled sums of ``t`` (replicates, n, n, 3) made already
    (:mod:`app.analysis.section_resamples`); without them they are made here."""
    t = np.asarray(t, dtype=float)
    t = with_votes(t)
    n = len(names)
    off = ~np.eye(n, dtype=bool)
    pooled = t.sum(axis=0)
    on_pair = np.where(off, pooled.sum(axis=-1), 0.0)
    active = np.flatnonzero((on_pair + on_pair.T).sum(axis=1) > 0)
    fit = (
        fit_btd(pooled[np.ix_(active, active)])
        if active.size >= 2
        else BTDFit(
            np.full(active.size, np.nan),
            np.nan,
            np.nan,
            np.nan,
            0,
            False,
            "fewer than two conditions were compared",
        )
    )
    ci = np.full((active.size + 2, 2), np.nan)
    used = 0
    if fit.converged and bootstrap > 0 and t.shape[0] > 1:
        sub = t[:, active][:, :, active]
        if resampled is None:
            sub = sub[canonical_participant_order(sub)]
            ci, used = bootstrap_btd(sub, bootstrap, seed, confidence)
        else:
            boot = resampled[:, active][:, :, active]
            ci, used = bootstrap_btd(sub, bootstrap, seed, confidence, resampled=boot)
    scores: dict[str, Any] = {c: None for c in names}
    intervals: dict[str, Any] = {c: [None, None] for c in names}
    for q, c in enumerate(active.tolist()):
        scores[names[c]] = json_number(fit.theta[q])
        intervals[names[c]] = [json_number(v) for v in ci[q]]
    missing = [names[c] for c in range(n) if c not in set(active.tolist())]
    note = fit.note or (f"never compared: {', '.join(missing)}" if missing else None)
    return {
        "scores": scores,
        "nu": json_number(fit.nu),
        "gamma": json_number(fit.gamma),
        "ci": intervals,
        "loglik": json_number(fit.loglik),
        "n": fit.votes,
        "gamma_ci": [json_number(v) for v in ci[-2]],
        "nu_ci": [json_number(v) for v in ci[-1]],
        "jod": {c: None if v is None else v * JOD_PER_LOG_WORTH for c, v in scores.items()},
        "jod_ci": {
            c: [None if v is None else v * JOD_PER_LOG_WORTH for v in iv]
            for c, iv in intervals.items()
        },
        "replicates": used,
        "note": note,
        "identical_pairs": side_check(t),
    }
