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
from scipy import sparse, stats

from app.analysis.btd import BOUND, JOD_PER_LOG_WORTH, fit_btd
from app.analysis.json_values import json_number
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


class _Model:
    """Dense effects z = (theta, lambda[, kappa], c) and participant effects b (P, n), with the
    vote counts ``t`` (P, K, n, n, 3), same-condition pairs set to 0."""

    def __init__(self, t: np.ndarray) -> None:
        self.P, self.K, self.n = t.shape[:3]
        self.ties = bool(t[..., 2].sum() > 0)
        self.use_p, self.use_c = self.P > 1, self.K > 1
        self.nf = self.n + 1 + int(self.ties)  # fixed effects
        self.m = self.nf + (self.K * self.n if self.use_c else 0)
        # the cells that hold votes, (participant, clip, left, right): a design shows each
        # participant a few pairs per clip, so most of the (P, K, n, n) cells are empty
        total = t.sum(axis=-1)
        cp, ck, ci, cj = np.nonzero(total)
        self.y = t[cp, ck, ci, cj]  # (N, 3)
        self.total = total[cp, ck, ci, cj]
        n, K, cells = self.n, self.K, len(cp)
        # the cells' worths in the flattened (P, K, n) worths
        self.at_wi, self.at_wj = (cp * K + ck) * n + ci, (cp * K + ck) * n + cj

        # A vote's log-likelihood depends on its worths through a_i - a_j alone, so its
        # derivative in a_j is minus that in a_i, and its n x n Hessian block is its second
        # derivative in that difference times (e_i - e_j)(e_i - e_j)'. The sums of the cells
        # into participants, clips and (participant, clip) blocks are therefore products with
        # fixed signed incidence matrices, made once, a column per cell (one sparse product
        # against several quantities at once is 3-10x faster than a bincount per quantity and
        # side, and the columns need no sorting to build)
        def incidence(rows: list[np.ndarray], signs: list[float], size: int) -> sparse.csc_array:
            at = np.empty(cells * len(rows), dtype=np.int32 if size < 2**31 else np.int64)
            for q, row in enumerate(rows):
                at[q :: len(rows)] = row
            values = np.empty(at.size)
            for q, sign in enumerate(signs):
                values[q :: len(rows)] = sign
            return sparse.csc_array(
                (values, at, np.arange(0, at.size + 1, len(rows), dtype=at.dtype)),
                shape=(size, cells),
            )

        self.to_p = incidence([cp * n + ci, cp * n + cj], [1.0, -1.0], self.P * n)
        self.to_k = incidence([ck * n + ci, ck * n + cj], [1.0, -1.0], K * n)

        # the n x n Hessian blocks of each (participant, clip): +1 at (i, i) and (j, j), -1 at
        # (i, j) and (j, i), laid out as the participant-dense block B (P, n, m) holds them,
        # after its fixed-effect columns, so the product lands in B itself
        self.sums = {"y_l": float(self.y[:, 0].sum()), "y_t": float(self.y[:, 2].sum())}
        self.work = {
            key: np.empty(cells) for key in ("delta", "pl", "pt", "d", "pr", "tpl", "tpt", "spare")
        }
        self.work["hess"] = np.empty(cells)
        self.work["per_cell"] = np.empty((cells, 3 if self.ties else 2))
        self.work["worth"] = np.empty((self.P, K, n))
        self.y_half = self.y[:, 0] + self.y[:, 2] / 2.0  # a left vote counts 1, undecided 1/2
        width, offset = (self.m, self.nf) if self.use_c else (K * n, 0)

        def at(row: np.ndarray, column: np.ndarray) -> np.ndarray:
            return (cp * n + row) * width + offset + ck * n + column

        self.to_block = incidence(
            [at(ci, ci), at(cj, cj), at(ci, cj), at(cj, ci)],
            [1.0, 1.0, -1.0, -1.0],
            self.P * n * width,
        )

    def _per_cell(
        self, z: np.ndarray, b: np.ndarray
    ) -> tuple[float, np.ndarray, np.ndarray, dict[str, float]]:
        """The log-likelihood and, per cell, in delta = a_i - a_j: the gradient, minus the
        cross derivatives with lambda (and kappa) as columns of one (N, 2 or 3) array, minus
        the second derivative, and the sums the fixed effects need (w_xy: minus the Hessian
        in the outcomes' logits, summed over the cells).

        Each cell relative to its right-hand outcome: the outcomes' odds are exp(lambda +
        delta) (left), exp(kappa + delta / 2) (undecided) and 1 (the right's worth cancels
        from the log-likelihood, the counts of a cell adding up to its total). The arrays over
        the cells are the model's own, rewritten in place at every call: this is the fit's
        inner loop, and arrays made anew each time cost as much again in page faults.
        """
        n, K, nf, w = self.n, self.K, self.nf, self.work
        lam = float(z[n])
        kap = float(z[n + 1]) if self.ties else 0.0
        worth = w["worth"]  # (P, K, n): theta + b_p + c_k
        if self.use_c:
            np.add(b[:, None, :], z[nf:].reshape(K, n)[None, :, :], out=worth)
        else:
            worth[:] = b[:, None, :]
        worth += z[:n]
        flat = worth.reshape(-1)
        delta, pl, pt, d, pr, tpl, tpt, spare = (
            w[k] for k in ("delta", "pl", "pt", "d", "pr", "tpl", "tpt", "spare")
        )
        np.take(flat, self.at_wi, out=delta)
        delta -= np.take(flat, self.at_wj, out=spare)
        # (exponents held within +-600: far beyond any estimable effect, short of overflow)
        np.add(delta, lam, out=pl)
        np.clip(pl, -600.0, 600.0, out=pl)
        np.exp(pl, out=pl)
        np.add(pl, 1.0, out=d)
        if self.ties:
            np.multiply(delta, 0.5, out=pt)
            pt += kap
            np.clip(pt, -600.0, 600.0, out=pt)
            np.exp(pt, out=pt)
            d += pt
        np.reciprocal(d, out=pr)
        pl *= pr  # P(left)
        np.log(d, out=d)
        y_l, y_t, total = self.y[:, 0], self.y[:, 2], self.total
        ll = float(y_l @ delta) + lam * self.sums["y_l"] - float(total @ d)
        np.multiply(total, pl, out=tpl)
        per_cell = w["per_cell"]
        g, with_l, hess = per_cell[:, 0], per_cell[:, 1], w["hess"]
        np.subtract(self.y_half, tpl, out=g)
        np.multiply(tpl, pr, out=hess)  # w_ll + w_lt + w_tt / 4, without ties
        with_l[:] = hess  # w_ll + w_lt / 2, without ties
        sums = {"tpl": float(tpl.sum())}
        sums["w_ll"] = sums["tpl"] - float(tpl @ pl)
        if self.ties:
            pt *= pr  # P(undecided)
            ll += float(y_t @ delta) / 2.0 + kap * self.sums["y_t"]
            np.multiply(total, pt, out=tpt)
            np.multiply(tpt, 0.5, out=spare)
            g -= spare
            np.subtract(1.0, pt, out=spare)
            spare *= tpt
            spare *= 0.25
            hess += spare
            np.multiply(tpl, pt, out=spare)
            spare *= 0.5
            with_l += spare
            np.subtract(pr, pl, out=spare)
            spare *= tpt
            np.multiply(spare, 0.5, out=per_cell[:, 2])  # w_lt + w_tt / 2
            sums["tpt"] = float(tpt.sum())
            sums["w_lt"] = -float(tpl @ pt)
            sums["w_tt"] = sums["tpt"] - float(tpt @ pt)
        return ll, per_cell, hess, sums

    def terms(self, z: np.ndarray, b: np.ndarray) -> dict[str, Any]:
        """Log-likelihood, its gradient and minus its Hessian in blocks: dense-dense C,
        participant blocks A (P, n, n) and participant-dense B (P, n, m).

        Every vote's worths are a = theta + b_p + c_k, so the derivatives are taken in the
        (participant, clip) worths of the cells that hold votes and summed into participants,
        clips or both (sparse products over the cells: the cost is linear in those cells, not
        in P K n^2). Local variables of a vote (i left, j right): delta = a_i - a_j, lambda,
        kappa; minus the Hessian of its log-likelihood in them is J' W J with W = N (diag(pi) -
        pi pi') and J the outcomes' coefficients (left 1, 1, 0; undecided 1/2, 0, 1; right 0).
        """
        P, K, n, m, nf = self.P, self.K, self.n, self.m, self.nf
        ll, per_cell, hess, sums = self._per_cell(z, b)
        by_p = self.to_p @ per_cell  # (P n, 2 or 3)
        by_k = self.to_k @ per_cell  # (K n, 2 or 3)
        # the (participant, clip) n x n blocks of minus the Hessian in the worths, in B
        placed = self.to_block @ hess
        if self.use_c:
            bb = placed.reshape(P, n, m)
            blocks = bb[:, :, nf:].reshape(P, n, K, n)
        else:
            bb, blocks = np.empty((P, n, m)), placed.reshape(P, n, K, n)
        g_p, h_al_p = by_p[:, 0].reshape(P, n), by_p[:, 1].reshape(P, n)
        aa = np.einsum("pikj->pij", blocks)  # (P, n, n); 5x faster than .sum(axis=2)
        per_clip = blocks.sum(axis=0).transpose(1, 0, 2)  # (K, n, n)
        gz, gb = np.zeros(m), np.zeros((P, n))
        cc = np.zeros((m, m))
        gz[:n] = g_p.sum(axis=0)
        gz[n] = self.sums["y_l"] - sums["tpl"]
        cc[:n, :n] = aa.sum(axis=0)
        cc[:n, n] = h_al_p.sum(axis=0)
        cc[n, n] = sums["w_ll"]
        if self.ties:
            h_ak_p = by_p[:, 2].reshape(P, n)
            gz[n + 1] = self.sums["y_t"] - sums["tpt"]
            cc[:n, n + 1] = h_ak_p.sum(axis=0)
            cc[n, n + 1] = sums["w_lt"]
            cc[n + 1, n + 1] = sums["w_tt"]
        if self.use_c:
            gz[nf:] = by_k[:, 0]
            for k in range(K):
                block = slice(nf + k * n, nf + (k + 1) * n)
                cc[block, block] = per_clip[k]
                cc[:n, block] = per_clip[k]
            cc[n, nf:] = by_k[:, 1]
            if self.ties:
                cc[n + 1, nf:] = by_k[:, 2]
        if self.use_p:
            gb = g_p
            bb[:, :, :n] = aa
            bb[:, :, n] = h_al_p
            if self.ties:
                bb[:, :, n + 1] = h_ak_p
        else:
            bb[:] = 0.0
            aa = np.zeros((P, n, n))
        upper = np.triu(cc, 1)
        cc = np.triu(cc) + upper.T  # filled above the diagonal only
        return {"ll": ll, "gz": gz, "gb": gb, "C": cc, "A": aa, "B": bb}

    def penalised(self, z: np.ndarray, b: np.ndarray, var: np.ndarray, ll: float) -> float:
        """F: minus the log-likelihood plus the random effects' Gaussian penalty (and the
        (sum theta)^2 / 2 that fixes theta's mean without moving the maximum)."""
        f = -ll + 0.5 * float(np.square(z[: self.n].sum()))
        if self.use_p:
            f += 0.5 * float((b**2).sum()) / var[0]
        if self.use_c:
            f += 0.5 * float((z[self.nf :] ** 2).sum()) / var[1]
        return f

    def active(self, var: np.ndarray) -> tuple[bool, bool]:
        """Which random effects are in the model: present in the design, variance not 0."""
        return self.use_p and var[0] > MIN_VARIANCE, self.use_c and var[1] > MIN_VARIANCE

    def solve(self, z: np.ndarray, b: np.ndarray, var: np.ndarray, t: dict[str, Any]) -> _Solve:
        """The Newton step of F (H^-1 times its gradient) through the Schur complement of the
        participant blocks, with the pieces of H^-1 the variance update needs. An absent
        effect (variance 0) is held at 0: its step returns it there."""
        n, m, nf = self.n, self.m, self.nf
        use_p, use_c = self.active(var)
        gz = -t["gz"]
        gz[:n] += z[:n].sum()
        s = t["C"].copy()
        s[:n, :n] += 1.0
        if use_c:
            gz[nf:] += z[nf:] / var[1]
            s[nf:, nf:] += np.eye(m - nf) / var[1]
        elif m > nf:
            s[nf:, :], s[:, nf:] = 0.0, 0.0
            s[nf:, nf:] = np.eye(m - nf)
            gz[nf:] = z[nf:]
        if not use_p:
            s_inv = np.linalg.inv(s)
            return _Solve(s_inv @ gz, b.copy(), s_inv, None, None)
        bb = t["B"]
        if not use_c and m > nf:  # the clip effects held at 0: no coupling to them
            bb = bb.copy()
            bb[:, :, nf:] = 0.0
        gb = -t["gb"] + b / var[0]
        a_inv = np.linalg.inv(t["A"] + np.eye(n) / var[0])
        x = a_inv @ bb  # A^-1 B, (P, n, m)
        # sums over participants and their conditions as one matrix product (tensordot's
        # transposes copied the (P, n, m) blocks: 17 ms against 2 ms at 1,000 participants)
        flat_b = bb.reshape(-1, m)
        s -= flat_b.T @ x.reshape(-1, m)
        s_inv = np.linalg.inv(s)
        a_inv_g = np.matmul(a_inv, gb[:, :, None])[:, :, 0]
        dz = s_inv @ (gz - flat_b.T @ a_inv_g.reshape(-1))
        return _Solve(dz, a_inv_g - x @ dz, s_inv, a_inv, x)

    def mode(
        self,
        var: np.ndarray,
        z: np.ndarray,
        b: np.ndarray,
        t: dict[str, Any] | None = None,
        *,
        tol: float = 1e-7,
        max_iter: int = 50,
        one_step: bool = False,
    ) -> tuple[np.ndarray, np.ndarray, _Solve, bool, dict[str, Any]]:
        """The joint mode of fixed and random effects for the given variances (Newton steps
        with step halving from ``z``, ``b``; ``t`` their :meth:`terms` if known, which do not
        depend on the variances), the solve there and its terms.

        ``one_step``: take one Newton step only and return its end with the solve at its start
        (the working-variate iteration of PQL, Breslow & Clayton 1993 sec. 2: one step of the
        effects per variance update). At the fixed point of the variance updates the step is 0
        and the solve is the mode's; on the way, each update costs one pass over the votes and
        one solve instead of two passes and three solves."""
        t = self.terms(z, b) if t is None else t
        f = self.penalised(z, b, var, t["ll"])
        for _ in range(max_iter):
            try:
                step = self.solve(z, b, var, t)
            except np.linalg.LinAlgError:
                break
            scale = 1.0
            for _half in range(30):
                z_new, b_new = z - scale * step.dz, b - scale * step.db
                t_new = self.terms(z_new, b_new)
                f_new = self.penalised(z_new, b_new, var, t_new["ll"])
                if f_new <= f + 1e-10 * max(1.0, abs(f)):
                    break
                scale /= 2.0
            else:  # no step decreases F beyond rounding: this is the mode
                return z, b, step, True, t
            if one_step:
                return z_new, b_new, step, True, t_new
            z, b, t, f = z_new, b_new, t_new, f_new
            moved = max(np.abs(scale * step.dz).max(), np.abs(scale * step.db).max(initial=0.0))
            if moved < tol:
                try:
                    return z, b, self.solve(z, b, var, t), True, t
                except np.linalg.LinAlgError:  # a flat direction at the mode: no curvature
                    break
        failed = _Solve(np.zeros_like(z), np.zeros_like(b), np.eye(self.m), None, None)
        return z, b, failed, False, t

    def variance_update(
        self, z: np.ndarray, b: np.ndarray, at: _Solve, var: np.ndarray
    ) -> np.ndarray:
        """Schall's (1991) REML update: var = (sum of squared modes + trace of their block of
        H^-1) / number of effects, for the participant and the clip effects (NaN: not in the
        design; an absent effect stays absent, the update cannot leave 0)."""
        out = np.full(2, np.nan)
        use_p, use_c = self.active(var)
        if self.use_p:
            out[0] = MIN_VARIANCE
        if use_p and at.a_inv is not None and at.x is not None:
            trace = np.trace(at.a_inv, axis1=1, axis2=2).sum() + float(
                ((at.x @ at.s_inv) * at.x).sum()
            )
            out[0] = (float((b**2).sum()) + trace) / b.size
        if self.use_c:
            out[1] = MIN_VARIANCE
        if use_c:
            c = z[self.nf :]
            trace_c = float(np.trace(at.s_inv[self.nf :, self.nf :]))
            out[1] = (float((c**2).sum()) + trace_c) / c.size
        return out


@dataclass(frozen=True)
class _Solve:
    dz: np.ndarray
    db: np.ndarray
    s_inv: np.ndarray  # the dense block of H^-1 (fixed and clip effects)
    a_inv: np.ndarray | None
    x: np.ndarray | None  # A^-1 B


#: The model's name as the report's heading and Table 9b give it: the random effects are
#: per participant and per clip on each condition's worth (b_pi, c_ki).
MODEL = "Bradley-Terry-Davidson with participant × condition and clip × condition random effects"
ESTIMATOR = "penalised quasi-likelihood, REML variances (Schall's update); Wald intervals"
MIN_VARIANCE = 1e-8  # a random effect taken as absent
#: The most variance updates a fit spends: a few dozen settle every study simulated
#: (benchmarks/bench_analysis.py), one stuck near a bound stops here and says so.
MAX_UPDATES = 300
START_VARIANCES = (0.25, 0.25)  # participant, clip: sd 0.5 log-worth units
CRAWL_VARIANCE = 0.01  # sd 0.1
NEGLIGIBLE_VARIANCE = 4e-4  # sd 0.02 log-worth units (0.018 JOD): taken as absent
LOG_MAX_VARIANCE = 3.0  # sd 4.48 log-worth units (4.1 JOD): the fit's bound on a variance
MAX_VARIANCE = float(np.exp(LOG_MAX_VARIANCE))


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
        return _fit(np.array(t, dtype=float), max_updates, tol, progress)


def _fit(
    t: np.ndarray,
    max_updates: int,
    tol: float,
    progress: Callable[[int, int], None] | None,
) -> MixedBTDFit:
    """:func:`fit_mixed_btd` itself."""
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
    model = _Model(t)
    state: dict[str, Any] = {
        "z": np.zeros(model.m),
        "b": np.zeros((P, n)),
        "t": None,
        "ok": True,
        "updates": 0,
    }

    def schall(log_var: np.ndarray) -> np.ndarray:
        """One variance update in log variances, from the mode at ``exp(log_var)``."""
        var = np.exp(log_var)
        z, b, at, ok, t = model.mode(var, state["z"], state["b"], state["t"], one_step=True)
        state.update(z=z, b=b, t=t, ok=state["ok"] and ok, updates=state["updates"] + 1)
        if progress is not None:
            progress(min(state["updates"], max_updates), max_updates)
        update = model.variance_update(z, b, at, var)
        new = np.where(np.isnan(update), var, update)
        new = np.where(new < NEGLIGIBLE_VARIANCE, MIN_VARIANCE, new)  # EM crawls near 0
        return np.log(new)

    # SQUAREM (Varadhan & Roland 2008, Scand. J. Stat. 35, 335-353, scheme S3): two updates
    # and an extrapolation along them per cycle; the fixed point is Schall's.
    log_var = np.log(np.array(START_VARIANCES))
    settled, probed, left = False, np.zeros(2, dtype=bool), np.inf
    while state["updates"] + 3 <= max_updates:
        one = schall(log_var)
        two = schall(one)
        r, v = one - log_var, two - 2.0 * one + log_var
        left = _distance_left(r, two - one)
        if left < tol:
            log_var, settled = two, True
            break
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
        saved = {key: state[key] for key in ("z", "b", "t", "ok")}
        from_jump = True
        try:
            new = schall(jump)
        except np.linalg.LinAlgError:
            state["ok"] = False
        if not state["ok"]:  # the extrapolation went too far: keep the plain updates
            state.update(saved)
            new, from_jump = schall(two), False
        if not state["ok"]:
            break
        probed |= crawl & (new > np.log(NEGLIGIBLE_VARIANCE))  # 0 is not the answer: no more
        # The update from the bound itself still points beyond it: the fixed point lies outside
        # the bound (the jump is clipped there, so more cycles would only circle it; 200 of
        # them took 0.3-0.4 s and ended as not converged anyway).
        outward = bounded & (new > LOG_MAX_VARIANCE) & from_jump
        if outward.any():
            which = " and ".join(
                name for name, out in zip(("participant", "clip"), outward, strict=True) if out
            )
            return failed(
                f"the fit did not converge (the {which} SD"
                + (" grows" if outward.sum() == 1 else "s grow")
                + f" beyond the fit's bound of {np.sqrt(MAX_VARIANCE):.1f} log-worth units)",
                int(state["updates"]),
            )
        log_var = new
    var = np.exp(log_var)
    iterations = int(state["updates"])
    z, b = state["z"], state["b"]
    z, b, at, ok, _ = model.mode(var, z, b, state["t"], tol=1e-9)
    if not (ok and state["ok"] and np.all(np.isfinite(z)) and np.abs(z[: model.nf]).max() < BOUND):
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
    t = np.asarray(t, dtype=float)
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
