"""The log-likelihood of the Bradley-Terry-Davidson model (:mod:`app.analysis.btd`) with its
gradient and Hessian, for many count arrays at once.

Davidson (1970), Davidson & Beaver (1977): each cell (i left, j right) is a multinomial logit
with linear predictors (lambda + theta_i, theta_j, kappa + (theta_i + theta_j) / 2) for its
answers left, right and undecided; :func:`design_matrix` holds their coefficients, and every
sum over cells and answers is a matrix product with it, so a thousand bootstrap refits take
one product per Newton step.
"""

from __future__ import annotations

import numpy as np


def design_matrix(n: int, ties: bool = True) -> np.ndarray:
    """(n, n, outcomes, n + 1 + ties) features of the linear predictors of each cell.

    Parameters in order: theta_1..theta_n, lambda = log g, kappa = log nu (only with ties).
    """
    k = n + 1 + int(ties)
    x = np.zeros((n, n, 2 + int(ties), k))
    idx = np.arange(n)
    x[idx, :, 0, idx] = 1.0  # left chosen: theta_i ...
    x[:, :, 0, n] = 1.0  # ... + lambda
    x[:, idx, 1, idx] = 1.0  # right chosen: theta_j
    if ties:
        x[idx, :, 2, idx] += 0.5  # undecided: (theta_i + theta_j) / 2 + kappa
        x[:, idx, 2, idx] += 0.5
        x[:, :, 2, n + 1] = 1.0
    return x


def vote_cells(counts: np.ndarray, ties: bool) -> np.ndarray:
    """(B, cells, outcomes) counts of the off-diagonal cells (identical pairs dropped)."""
    n = counts.shape[-2]
    off = ~np.eye(n, dtype=bool)
    c = counts[..., off, :]
    return c if ties else c[..., :2]


def batched_terms(
    beta: np.ndarray, cells: np.ndarray, x: np.ndarray, penalty: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Objective (negative log-likelihood plus (sum theta)^2 / 2), gradient and Hessian, batched.

    The penalty fixes the mean of theta at 0 without moving the maximum (the likelihood does not
    change when every theta moves together) and makes the Hessian invertible in that direction.
    """
    n_cells, n_out, k = x.shape
    b = len(beta)
    # every sum over cells and outcomes as a matrix product (einsum's loops took 3x as long)
    flat_x = x.reshape(n_cells * n_out, k)
    eta = (beta @ flat_x.T).reshape(b, n_cells, n_out)
    # (reductions over the 2 or 3 outcomes slice by slice: numpy's along a short last axis
    # took 5-10 times as long)
    eta_max = _outcomes(np.maximum, eta)
    p = np.exp(eta - eta_max[..., None])
    d = _outcomes(np.add, p)
    log_d = eta_max + np.log(d)
    p /= d[..., None]
    total = _outcomes(np.add, cells)
    nll = -((cells * eta).reshape(b, -1).sum(axis=1) - (total * log_d).sum(axis=1))
    weighted_p = total[..., None] * p
    grad = -((cells - weighted_p).reshape(b, -1) @ flat_x)
    mean_x = (p.reshape(b, -1) @ _by_cell(x)).reshape(b, n_cells, k)
    second = weighted_p.reshape(b, -1) @ _outer(x)
    weighted = np.swapaxes(total[..., None] * mean_x, 1, 2)
    hess = second.reshape(-1, k, k) - weighted @ mean_x
    if penalty:
        n = k - 1 - int(n_out == 3)
        s = beta[:, :n].sum(axis=1)
        nll = nll + 0.5 * s**2
        grad[:, :n] += s[:, None]
        hess[:, :n, :n] += 1.0
    return nll, grad, hess


def _outcomes(op: np.ufunc, a: np.ndarray) -> np.ndarray:
    """``op`` reduced over the last axis (the outcomes), one slice at a time."""
    out = op(a[..., 0], a[..., 1])
    for q in range(2, a.shape[-1]):
        op(out, a[..., q], out=out)
    return out


def _by_cell(x: np.ndarray) -> np.ndarray:
    """(cells outcomes, cells k): the design of each cell on the block diagonal, so that
    outcome weights times it sum each cell's features."""
    n_cells, n_out, k = x.shape
    out = np.zeros((n_cells, n_out, n_cells, k))
    out[np.arange(n_cells), :, np.arange(n_cells), :] = x
    return out.reshape(n_cells * n_out, n_cells * k)


def _outer(x: np.ndarray) -> np.ndarray:
    """(cells outcomes, k k): each outcome's features times themselves."""
    n_cells, n_out, k = x.shape
    return np.einsum("cok,col->cokl", x, x).reshape(n_cells * n_out, k * k)
