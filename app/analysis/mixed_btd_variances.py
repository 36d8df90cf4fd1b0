"""The variances of the mixed Bradley-Terry-Davidson model (:mod:`app.analysis.mixed_btd`):
Schall's REML update (Schall 1991, Biometrika 78, 719-727) iterated to its fixed point,
accelerated by SQUAREM (Varadhan & Roland 2008).

Each update takes the effects one Newton step nearer their mode at the variances given (the
working-variate iteration of PQL, as ``glmmPQL`` alternates one weighted fit with the
variances) and sets each variance to the sum of its squared modes plus the trace of its block
of H^-1, over the number of effects
(:func:`schall_update`). A SQUAREM cycle takes
two updates and extrapolates along them, with a step length per variance; a small variance
still falling at nearly the same pace is EM's crawl towards 0 and is probed at sd 0.02 at
once; a variance below sd 0.02 is taken as 0; the jump stops at the fit's bound on a
variance, and an update from that bound still pointing beyond it ends the fit. The updates
stop when the distance left to their fixed point, estimated from the rate of the last two, is
under ``tol``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.analysis.mixed_btd_model import MIN_VARIANCE, MixedBTDModel, Solve

#: Where the iteration starts, where it probes a crawl, what it takes as 0 and its bound.
START_VARIANCES = (0.25, 0.25)  # participant, clip: sd 0.5 log-worth units
CRAWL_VARIANCE = 0.01  # sd 0.1
NEGLIGIBLE_VARIANCE = 4e-4  # sd 0.02 log-worth units (0.018 JOD): taken as absent
LOG_MAX_VARIANCE = 3.0  # sd 4.48 log-worth units (4.1 JOD): the fit's bound on a variance
MAX_VARIANCE = float(np.exp(LOG_MAX_VARIANCE))


@dataclass
class SchallUpdates:
    """Schall's variance update as the iteration takes it, in log variances: each finds the
    effects one Newton step nearer their mode at the variances given (from the effects ``z``,
    ``b`` and terms ``t`` of the update before), counts itself in ``count`` and reports to
    ``progress``; ``ok`` turns False for good once a step fails."""

    model: MixedBTDModel
    z: np.ndarray
    b: np.ndarray
    max_updates: int
    progress: Callable[[int, int], None] | None
    t: dict[str, Any] | None = None
    ok: bool = True
    count: int = 0

    def __call__(self, log_var: np.ndarray) -> np.ndarray:
        """One variance update in log variances, from the mode at ``exp(log_var)``."""
        var = np.exp(log_var)
        z, b, at, ok, t = self.model.mode(var, self.z, self.b, self.t, one_step=True)
        self.z, self.b, self.t, self.ok, self.count = z, b, t, self.ok and ok, self.count + 1
        if self.progress is not None:
            self.progress(min(self.count, self.max_updates), self.max_updates)
        update = schall_update(self.model, z, b, at, var)
        new = np.where(np.isnan(update), var, update)
        new = np.where(new < NEGLIGIBLE_VARIANCE, MIN_VARIANCE, new)  # EM crawls near 0
        return np.log(new)

    def saved(self) -> tuple[np.ndarray, np.ndarray, dict[str, Any] | None, bool]:
        """The effects, terms and state of the last update, to go back to."""
        return self.z, self.b, self.t, self.ok

    def restore(self, saved: tuple[np.ndarray, np.ndarray, dict[str, Any] | None, bool]) -> None:
        self.z, self.b, self.t, self.ok = saved


def schall_update(
    model: MixedBTDModel, z: np.ndarray, b: np.ndarray, at: Solve, var: np.ndarray
) -> np.ndarray:
    """Schall's (1991) REML update: var = (sum of squared modes + trace of their block of
    H^-1) / number of effects, for the participant and the clip effects (NaN: not in the
    design; an absent effect stays absent, the update cannot leave 0)."""
    out = np.full(2, np.nan)
    use_p, use_c = model.active(var)
    if model.use_p:
        out[0] = MIN_VARIANCE
    if use_p and at.a_inv is not None and at.x is not None:
        # tr(X S^-1 X') over the participants = tr(S^-1 X'X): one m x m product of the
        # (P n, m) rows of X, no (P, n, m) temporaries
        flat_x = at.x.reshape(-1, at.x.shape[-1])
        trace = np.trace(at.a_inv, axis1=1, axis2=2).sum() + float(
            (at.s_inv * (flat_x.T @ flat_x)).sum()
        )
        out[0] = (float((b**2).sum()) + trace) / b.size
    if model.use_c:
        out[1] = MIN_VARIANCE
    if use_c:
        c = z[model.nf :]
        trace_c = float(np.trace(at.s_inv[model.nf :, model.nf :]))
        out[1] = (float((c**2).sum()) + trace_c) / c.size
    return out


def settle(
    updates: SchallUpdates, tol: float, start: np.ndarray | None = None
) -> tuple[np.ndarray, bool, float, str | None]:
    """The log variances at the fixed point of Schall's update, by SQUAREM cycles from
    ``start`` (variances; default :data:`START_VARIANCES`) until the distance left
    (:func:`_distance_left`) is under ``tol`` or the updates reach their cap.

    Returns the log variances, whether they settled, the distance left, and the note of a fit
    that ends at the bound (:func:`_beyond_bound`; None otherwise).

    SQUAREM (Varadhan & Roland 2008, Scand. J. Stat. 35, 335-353, scheme S3): two updates
    and an extrapolation along them per cycle (:func:`_extrapolation`); the fixed point is
    Schall's. The update from the extrapolated point and the next one are already two plain
    updates in a row, so the stop is tested on them before a cycle's second update (one
    update fewer on the fits that end there).
    """
    log_var = np.log(np.array(START_VARIANCES if start is None else start, dtype=float))
    settled, probed, left = False, np.zeros(2, dtype=bool), np.inf
    before = None  # where the update that gave log_var started (the jump, or two)
    while updates.count + 3 <= updates.max_updates:
        one = updates(log_var)
        if before is not None:  # before -> log_var -> one: two plain updates already
            left = _distance_left(log_var - before, one - log_var)
            if left < tol:
                log_var, settled = one, True
                break
        two = updates(one)
        r, v = one - log_var, two - 2.0 * one + log_var
        left = _distance_left(r, two - one)
        if left < tol:
            log_var, settled = two, True
            break
        jump, bounded, crawl = _extrapolation(log_var, one, two, r, v, probed)
        saved = updates.saved()
        from_jump = True
        try:
            new = updates(jump)
        except np.linalg.LinAlgError:
            updates.ok = False
        if not updates.ok:  # the extrapolation went too far: keep the plain updates
            updates.restore(saved)
            new, from_jump = updates(two), False
        if not updates.ok:
            break
        probed |= crawl & (new > np.log(NEGLIGIBLE_VARIANCE))  # 0 is not the answer: no more
        beyond = _beyond_bound(bounded & (new > LOG_MAX_VARIANCE) & from_jump)
        if beyond is not None:
            return log_var, settled, left, beyond
        log_var, before = new, jump if from_jump else two
    return log_var, settled, left, None


def moment_variances(model: MixedBTDModel, terms: dict[str, Any]) -> np.ndarray:
    """Where the variance updates start: moment estimates of the participant and clip
    variances from the :meth:`~app.analysis.mixed_btd_model.MixedBTDModel.terms` at the fixed
    model's estimates with every random effect 0, :data:`START_VARIANCES` where none is
    usable.

    Each participant's effects estimated alone, one Newton step from 0 without the penalty
    (b_p = A_p^+ g_p, the pseudo-inverse: effects move the likelihood only through their
    differences), have about the covariance sd^2 I + A_p^+ on the A_p^+ A_p subspace, so
    (sum of |b_p|^2 - sum of tr A_p^+) / (sum of the subspaces' dimensions) estimates sd^2;
    the clip effects likewise from the clip blocks of C (Henderson's method 1 in spirit:
    Searle, Casella & McCulloch 1992, sec. 5.1). The estimate starts the iteration nearer
    its fixed point (0.064 for a REML estimate of 0.067 at 10,000 participants; a start of
    0.25 took two SQUAREM cycles more); the fixed point itself is Schall's. An estimate at or
    below :data:`NEGLIGIBLE_VARIANCE` keeps the usual start, and one below
    :data:`CRAWL_VARIANCE` starts there, so the crawl towards 0 is still probed as before.
    """
    start = np.array(START_VARIANCES, dtype=float)
    n, nf = model.n, model.nf
    if model.use_p:
        start[0] = _moment(terms["A"], terms["gb"], start[0])
    if model.use_c:
        k = model.K
        c = terms["C"][nf:, nf:].reshape(k, n, k, n)
        blocks = c[np.arange(k), :, np.arange(k), :]  # (K, n, n): each clip's own block
        start[1] = _moment(blocks, terms["gz"][nf:].reshape(k, n), start[1])
    return start


def _moment(hessians: np.ndarray, gradients: np.ndarray, usual: float) -> float:
    """sd^2 from effects estimated one at a time (:func:`moment_variances`), or ``usual``."""
    with np.errstate(invalid="ignore", over="ignore"):
        plus = np.linalg.pinv(hessians, rcond=1e-9, hermitian=True)
        effects = np.matmul(plus, gradients[..., None])[..., 0]
        dims = float(np.trace(plus @ hessians, axis1=1, axis2=2).sum())
        spread = float((effects**2).sum()) - float(np.trace(plus, axis1=1, axis2=2).sum())
    if not (dims > 0.5 and np.isfinite(spread)) or spread / dims <= NEGLIGIBLE_VARIANCE:
        return usual
    return float(np.clip(spread / dims, CRAWL_VARIANCE, MAX_VARIANCE))


def _extrapolation(
    log_var: np.ndarray,
    one: np.ndarray,
    two: np.ndarray,
    r: np.ndarray,
    v: np.ndarray,
    probed: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SQUAREM's jump from ``log_var`` along its two plain updates ``one`` and ``two`` (``r``
    the first step, ``v`` the change between the steps), clipped to the bound; which
    variances the jump put at the bound; and which are probed at ``NEGLIGIBLE_VARIANCE``
    (the crawl probe: a small variance still falling at nearly the same pace, not ``probed``
    before)."""
    # a step length per variance: the two settle at their own pace, and the jitter of a
    # settled one must not hold back the extrapolation of one still crawling
    alpha = np.minimum(-1.0, -np.abs(r) / np.maximum(np.abs(v), 1e-12))
    jump = log_var - 2.0 * alpha * r + alpha**2 * v
    # at most a factor e**1.5 beyond the plain updates, and not below NEGLIGIBLE_VARIANCE:
    # the update there, not the jump, decides on 0
    jump = np.clip(
        two + np.clip(jump - two, -1.5, 1.5), np.log(NEGLIGIBLE_VARIANCE), LOG_MAX_VARIANCE
    )
    bounded = jump >= LOG_MAX_VARIANCE
    # a small variance still falling at nearly the same pace is EM's crawl towards 0:
    # try NEGLIGIBLE_VARIANCE at once (its update says whether 0 is the answer)
    crawl = (r < 0) & (two - one < 0.5 * r) & (two < np.log(CRAWL_VARIANCE)) & ~probed
    jump = np.where(crawl, np.log(NEGLIGIBLE_VARIANCE), jump)
    jump = np.where(two <= np.log(MIN_VARIANCE) + 1e-9, two, jump)  # absent stays so
    return jump, bounded, crawl


def _beyond_bound(outward: np.ndarray) -> str | None:
    """The note of a fit whose update from the bound itself still points beyond it, for the
    variances ``outward`` (participant, clip) marks; None when none does.

    The fixed point then lies outside the bound (the jump is clipped there, so more cycles
    would only circle it; 200 of them took 0.3-0.4 s and ended as not converged anyway).
    """
    if not outward.any():
        return None
    which = " and ".join(
        name for name, out in zip(("participant", "clip"), outward, strict=True) if out
    )
    return (
        f"the fit did not converge (the {which} SD"
        + (" grows" if outward.sum() == 1 else "s grow")
        + f" beyond the fit's bound of {np.sqrt(MAX_VARIANCE):.1f} log-worth units)"
    )


def _distance_left(first: np.ndarray, second: np.ndarray) -> float:
    """How far two successive plain updates ``first`` and ``second`` (in log variances) leave
    the iteration from its fixed point: the rest of a geometric series, ``|second| * rho / (1 -
    rho)`` with the rate ``rho = |second / first|`` per variance (capped at 0.999), plus the
    last step.

    A small step alone does not say the variances have settled: near a variance of 0, EM
    (Schall's update is one) crawls with a rate close to 1, and a stop on the step size
    reported a clip SD of 0.11 where the REML estimate is 0 (EM's linear rate is the largest
    fraction of missing information: Dempster, Laird & Rubin 1977, JRSS B 39, 1-38).

    >>> _distance_left(np.array([1e-6, 1e-3]), np.array([5e-7, 1e-7]))  # rates 0.5 and 1e-4
    1e-06
    >>> round(_distance_left(np.array([1e-5]), np.array([0.99e-5])), 7)  # a crawl, rate 0.99
    0.00099
    """
    first, second = np.abs(first), np.abs(second)
    rate = np.minimum(np.divide(second, first, out=np.zeros_like(second), where=first > 0), 0.999)
    return float(np.max(second + second * rate / (1.0 - rate), initial=0.0))
