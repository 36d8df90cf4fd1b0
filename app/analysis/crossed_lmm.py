"""A linear mixed model with crossed random intercepts, fitted by REML as lme4 fits it.

The rating designs' model (:mod:`app.analysis.ratings`): each rating y of condition i by
participant p on clip k is

    y_pki = mu_i + u_p + v_k + e_pki,   u ~ N(0, s_p^2), v ~ N(0, s_k^2), e ~ N(0, s^2)

with participants and clips crossed (Baayen, Davidson & Bates 2008). As in lme4 (Bates,
Maechler, Bolker & Walker 2015, "Fitting linear mixed-effects models using lme4", J. Stat.
Softw. 67(1), sec. 3), the random effects are written b = Lambda(theta) u with u ~ N(0, s^2 I)
and theta = (s_p / s, s_k / s); for each theta the penalised least squares system

    [ Lambda'Z'Z Lambda + I   Lambda'Z'X ] [u]   [Lambda'Z'y]
    [ X'Z Lambda              X'X        ] [b] = [X'y      ]

is solved, and the REML criterion profiled over beta and s^2 (their eq. 41),

    d(theta) = log|L_theta|^2 + log|R_X|^2 + (n - p) (1 + log(2 pi r^2 / (n - p))),

is minimised over theta >= 0 (a variance may be 0). Here Z'Z is two diagonal blocks (each
participant, each clip counted) joined by the participant x clip table of counts, so the
Cholesky factor comes from eliminating the larger factor's diagonal block and factoring the
smaller one's Schur complement densely: an evaluation costs O(n) for the ratings and
O(m s + s^3) for m levels of the larger factor and s of the smaller (10,000 participants on
10 clips: a few milliseconds). statsmodels' MixedLM, used before, held a dense dummy column per
participant in one group: 100 participants took 8 s, 1,000 did not finish in 3 GB.

The fixed effects are the condition means (one indicator per condition, no intercept);
``cov`` is ``s^2 (R_X' R_X)^{-1}``, the covariance of their estimates lme4 reports.

Example
-------
>>> rng = np.random.default_rng(0)
>>> p, k = np.repeat(np.arange(30), 8), np.tile(np.arange(8), 30)
>>> c = (p + k) % 2
>>> y = np.where(c, 3.5, 2.5) + rng.normal(0, 0.6, 30)[p] + rng.normal(0, 0.3, 8)[k]
>>> y = y + rng.normal(0, 0.5, len(p))
>>> fit = fit_crossed(y, c, [p, k])
>>> np.round(fit.beta, 3).tolist(), np.round(fit.sd, 3).tolist(), round(fit.residual, 3)
([2.379, 3.402], [0.469, 0.181], 0.532)

(lme4's ``lmer(y ~ 0 + c + (1|p) + (1|k))`` on the same data: 2.379, 3.402; 0.469, 0.181;
0.532.)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import linalg, optimize, sparse


@dataclass(frozen=True)
class CrossedFit:
    """A REML fit: fixed effects ``beta`` (one per level of the fixed factor), their
    covariance ``cov``, the random-effect sds ``sd`` (one per grouping factor, in the order
    given), the residual sd, the REML criterion at the optimum, and whether the optimiser
    converged (with its message)."""

    beta: np.ndarray
    cov: np.ndarray
    sd: np.ndarray
    residual: float
    reml: float
    converged: bool
    message: str


class _Design:
    """The sufficient statistics of one data set: counts and sums per level and per cell (the
    criterion never reads the ratings again)."""

    def __init__(self, y: np.ndarray, fixed: np.ndarray, groups: Sequence[np.ndarray]) -> None:
        y = np.asarray(y, dtype=np.float64)
        self.n = len(y)
        self.fixed = np.asarray(fixed, dtype=np.int64)
        self.p = int(self.fixed.max()) + 1 if self.n else 0
        codes = [np.asarray(g, dtype=np.int64) for g in groups]
        sizes = [int(g.max()) + 1 for g in codes]
        # the larger factor is eliminated first (its block is diagonal)
        self.order = sorted(range(len(codes)), key=lambda j: -sizes[j])
        self.groups = [codes[j] for j in self.order]
        self.sizes = [sizes[j] for j in self.order]
        self.yty = float(y @ y)
        self.xtx = np.bincount(self.fixed, minlength=self.p).astype(np.float64)
        self.xty = np.bincount(self.fixed, weights=y, minlength=self.p)
        self.count = [np.bincount(g, minlength=m).astype(np.float64) for g, m in self._pairs()]
        self.zty = [np.bincount(g, weights=y, minlength=m) for g, m in self._pairs()]
        self.ztx = [_table(g, m, self.fixed, self.p) for g, m in self._pairs()]
        # larger x smaller factor: counts per cell
        self.cross = _table(*self._pairs()[0], *self._pairs()[1]) if len(codes) == 2 else None

    def _pairs(self) -> list[tuple[np.ndarray, int]]:
        return list(zip(self.groups, self.sizes, strict=True))


def _table(a: np.ndarray, m: int, b: np.ndarray, k: int) -> np.ndarray | sparse.csr_matrix:
    """Counts per (a, b) cell: dense while small (the usual few conditions and clips), else
    sparse (thousands of clips)."""
    if m * k <= DENSE_CELLS:
        return np.bincount(a * k + b, minlength=m * k).astype(np.float64).reshape(m, k)
    return sparse.csr_matrix((np.ones(len(a)), (a, b)), shape=(m, k))


def _dense(x: Any) -> np.ndarray:
    """A dense array of a dense or sparse matrix."""
    return np.asarray(x.toarray()) if sparse.issparse(x) else np.asarray(x)


#: Criterion evaluations the optimiser may spend (it takes 100-200).
MAX_EVALUATIONS = 4000
#: A penalised residual sum of squares below this share of y'y is rounding, not variance.
RESIDUAL_FLOOR = 1e-12
#: Cells of a count table held dense (at most 40 MB of float64).
DENSE_CELLS = 5_000_000


def _solve(d: _Design, theta: np.ndarray) -> tuple[float, dict[str, np.ndarray | float]]:
    """The profiled REML criterion at ``theta`` (in the order of ``d.groups``: the larger
    factor first) and the pieces of the solution."""
    lam = np.asarray(theta, dtype=np.float64)
    # block 1: the larger factor, diagonal
    d1 = lam[0] ** 2 * d.count[0] + 1.0
    inv1 = 1.0 / d1
    m13 = d.ztx[0] * lam[0]  # (m, p)
    b1 = lam[0] * d.zty[0]
    logdet = float(np.log(d1).sum())
    s33 = np.diag(d.xtx) - _dense(
        m13.T @ (m13.multiply(inv1[:, None]) if sparse.issparse(m13) else m13 * inv1[:, None])
    )
    r3 = d.xty - m13.T @ (inv1 * b1)
    u_small = np.zeros(0)
    b2 = np.zeros(0)
    if d.cross is not None:
        b = d.cross * (lam[0] * lam[1])  # (m, s)
        binv = b.multiply(inv1[:, None]) if sparse.issparse(b) else b * inv1[:, None]
        s22 = np.diag(lam[1] ** 2 * d.count[1] + 1.0) - _dense(b.T @ binv)
        s23 = _dense(d.ztx[1]) * lam[1] - _dense(binv.T @ m13)
        b2 = lam[1] * d.zty[1]
        r2 = b2 - b.T @ (inv1 * b1)
        l22 = linalg.cholesky(s22, lower=True)
        logdet += 2.0 * float(np.log(np.diag(l22)).sum())
        t23 = linalg.solve_triangular(l22, s23, lower=True)
        t2 = linalg.solve_triangular(l22, r2, lower=True)
        s33 = s33 - t23.T @ t23
        r3 = r3 - t23.T @ t2
    rx = linalg.cholesky(s33, lower=False)
    beta = linalg.cho_solve((rx, False), r3)
    if d.cross is not None:
        u_small = linalg.solve_triangular(l22.T, t2 - t23 @ beta, lower=False)
        u_big = inv1 * (b1 - b @ u_small - m13 @ beta)
    else:
        u_big = inv1 * (b1 - m13 @ beta)
    # at the penalised least squares solution, r^2 = y'y - (its right-hand side) . (solution)
    r2sum = d.yty - float(b1 @ u_big) - float(b2 @ u_small) - float(d.xty @ beta)
    dof = d.n - d.p
    if not r2sum > RESIDUAL_FLOOR * max(d.yty, 1e-300):
        # the ratings are fitted exactly (to rounding): no variance is estimable
        raise FloatingPointError("no residual variance")
    logdet_x = 2.0 * float(np.log(np.abs(np.diag(rx))).sum())
    reml = logdet + logdet_x + dof * (1.0 + np.log(2.0 * np.pi * r2sum / dof))
    return float(reml), {"beta": beta, "rx": rx, "sigma2": r2sum / dof}


def fit_crossed(
    y: np.ndarray,
    fixed: np.ndarray,
    groups: Sequence[np.ndarray],
    *,
    start: Sequence[float] | None = None,
) -> CrossedFit:
    """REML fit of ``y`` on the levels ``fixed`` (integer codes 0..p-1, one mean each) with a
    random intercept for each of one or two crossed grouping factors ``groups`` (integer codes
    0..m-1). See the module docstring."""
    d = _Design(y, fixed, groups)
    if len(d.groups) not in (1, 2):
        raise ValueError("one or two grouping factors")
    if d.n <= d.p:
        raise ValueError("fewer ratings than fixed effects")

    def criterion(theta: np.ndarray) -> float:
        try:
            return _solve(d, np.maximum(theta, 0.0))[0]
        except (linalg.LinAlgError, ValueError, FloatingPointError):
            return np.inf

    x0 = np.ones(len(d.groups)) if start is None else np.asarray(start, dtype=np.float64)[d.order]
    bounds = [(0.0, None)] * len(d.groups)
    # Powell's derivative-free search (bounded), as lme4 uses a derivative-free one (BOBYQA):
    # the criterion is a sum of terms of size n, so finite-difference gradients are noisy
    if not np.isfinite(criterion(x0)):
        raise ValueError("the ratings leave no residual variance to estimate")
    with np.errstate(all="ignore"):  # a step into a region without a fit scores inf
        best = optimize.minimize(
            criterion,
            x0,
            method="Powell",
            bounds=bounds,
            options={"xtol": 1e-9, "ftol": 1e-13, "maxfev": MAX_EVALUATIONS},
        )
    # a variance at its bound (lme4's fits end there too): compare the boundary fits
    candidates = [best.x] + [
        np.where(np.arange(len(best.x)) == j, 0.0, best.x) for j in range(len(best.x))
    ]
    theta = np.maximum(min(candidates, key=criterion), 0.0)
    reml, parts = _solve(d, theta)
    sigma2 = float(parts["sigma2"])  # type: ignore[arg-type]
    given = np.empty_like(theta)
    given[d.order] = theta  # back to the order the factors were given in
    rx = np.asarray(parts["rx"])
    rinv = linalg.solve_triangular(rx, np.eye(d.p), lower=False)
    cov = sigma2 * (rinv @ rinv.T)
    return CrossedFit(
        beta=np.asarray(parts["beta"]),
        cov=cov,
        sd=np.sqrt(sigma2) * np.maximum(given, 0.0),
        residual=float(np.sqrt(sigma2)),
        reml=float(reml),
        converged=bool(best.success),
        message=str(best.message),
    )
