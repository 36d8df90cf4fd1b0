"""Multi-output ARX models: least-squares fit on a lag matrix and free-running simulation.

Thesis sec. 4.3.4.2 (after Ljung): the output at frame ``t`` is a linear combination of the
``na`` previous outputs and ``nb`` inputs delayed by ``nk`` frames,

    y_t = sum_{i=1}^{na} A_i y_{t-i} + sum_{j=0}^{nb-1} B_j u_{t-nk-j} + c + e_t,

with ``y`` the head angles (pitch, yaw, roll; each output sees the past of all three, the
thesis' "previous predictions of head movements") and ``u`` the speech inputs. The thesis
uses ``na = nb = 4``, ``nk = 1``. Fitting minimises the one-step equation error by least
squares (optionally ridge-regularised); generation runs the model free from the speech alone,
feeding back its own outputs.

Example
-------
>>> rng = np.random.default_rng(0)
>>> u = rng.standard_normal((2000, 1))
>>> true = ArxModel(a=np.array([[[0.5]]]), b=np.array([[[2.0]]]), c=np.zeros(1), nk=1)
>>> y = true.simulate(u, noise=0.01 * rng.standard_normal((2000, 1)))
>>> fit = fit_arx(y, u, na=1, nb=1, nk=1)
>>> round(float(fit.a[0, 0, 0]), 2), round(float(fit.b[0, 0, 0]), 2)
(0.5, 2.0)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(eq=False)
class ArxModel:
    """``y_t = sum_i a[i] @ y_{t-1-i} + sum_j b[j] @ u_{t-nk-j} + c``.

    Attributes
    ----------
    a : (na, n_out, n_out) autoregressive matrices.
    b : (nb, n_out, n_in) input matrices.
    c : (n_out,) intercept.
    nk : input delay in frames (>= 0).
    y_rest : (n_out,) output assumed before the first frame (the training mean by default).
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    nk: int = 1
    y_rest: np.ndarray | None = None
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.a = np.asarray(self.a, dtype=np.float64)
        self.b = np.asarray(self.b, dtype=np.float64)
        self.c = np.asarray(self.c, dtype=np.float64)
        if self.y_rest is None:
            self.y_rest = np.zeros(self.n_out)
        self.y_rest = np.asarray(self.y_rest, dtype=np.float64)

    @property
    def na(self) -> int:
        return int(self.a.shape[0])

    @property
    def nb(self) -> int:
        return int(self.b.shape[0])

    @property
    def n_out(self) -> int:
        return int(self.c.shape[0])

    @property
    def n_in(self) -> int:
        return int(self.b.shape[2])

    def spectral_radius(self) -> float:
        """Largest |eigenvalue| of the AR companion matrix; < 1 means the simulation is stable."""
        if self.na == 0:
            return 0.0
        m = self.n_out
        comp = np.zeros((self.na * m, self.na * m))
        comp[:m] = np.hstack(list(self.a))
        comp[m:, :-m] = np.eye((self.na - 1) * m)
        return float(np.max(np.abs(np.linalg.eigvals(comp))))

    def exogenous(self, u: np.ndarray) -> np.ndarray:
        """``c + sum_j b[j] @ u_{t-nk-j}`` for every frame; inputs before frame 0 hold u_0."""
        u = _as_2d(u)
        n = len(u)
        out = np.tile(self.c, (n, 1))
        if n == 0:
            return out
        lag = self.nk + np.arange(self.nb)
        padded = np.vstack([np.repeat(u[:1], int(lag.max(initial=0)), axis=0), u])
        start = int(lag.max(initial=0))
        for j, d in enumerate(lag):
            out += padded[start - d : start - d + n] @ self.b[j].T
        return out

    def simulate(
        self, u: np.ndarray, *, noise: np.ndarray | None = None, from_rest: bool = False
    ) -> np.ndarray:
        """Run the model free from inputs ``u`` (n, n_in); returns outputs (n, n_out).

        Outputs before the first frame are ``y_rest``; ``noise`` (n, n_out) is added to the
        equation (to simulate a system with equation error). With ``from_rest`` the result is
        the motion caused by the input's changes since the first frame: by linearity, the
        response to ``u - u[0]`` from a zero state (no intercept), which stays exactly 0 while
        the input holds its first value, so a model never swings in the silence before speech.
        """
        if from_rest and len(u):
            u = _as_2d(u)
            u = u - u[:1]
            at_rest = ArxModel(self.a, self.b, np.zeros(self.n_out), self.nk, np.zeros(self.n_out))
            return at_rest.simulate(u, noise=noise)
        drive = self.exogenous(u)
        if noise is not None:
            drive = drive + noise
        n, m = drive.shape
        y = np.empty((n, m))
        start = np.zeros(m) if self.y_rest is None else self.y_rest
        hist = np.tile(start, self.na)  # [y_{t-1}, y_{t-2}, ...] flattened
        big_a = np.hstack(list(self.a)) if self.na else np.zeros((m, 0))
        for t in range(n):  # the recursion itself is inherently sequential
            y[t] = drive[t] + big_a @ hist
            if self.na:
                hist = np.concatenate([y[t], hist[:-m]])
        return y

    def predict_one_step(self, y: np.ndarray, u: np.ndarray) -> np.ndarray:
        """One-step-ahead predictions from measured past outputs (for fit diagnostics)."""
        y = _as_2d(y)
        pred = self.exogenous(u)
        rest = np.zeros(self.n_out) if self.y_rest is None else self.y_rest
        padded = np.vstack([np.tile(rest, (self.na, 1)), y])
        for i in range(self.na):
            pred += padded[self.na - 1 - i : self.na - 1 - i + len(y)] @ self.a[i].T
        return pred

    def to_dict(self) -> dict[str, Any]:
        return {
            "na": self.na,
            "nb": self.nb,
            "nk": self.nk,
            "a": self.a.tolist(),
            "b": self.b.tolist(),
            "c": self.c.tolist(),
            "y_rest": np.asarray(self.y_rest).tolist(),
            "info": self.info,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ArxModel:
        a = np.asarray(d["a"], dtype=np.float64).reshape(int(d["na"]), -1, len(d["c"]))
        b = np.asarray(d["b"], dtype=np.float64).reshape(int(d["nb"]), len(d["c"]), -1)
        return cls(
            a=a,
            b=b,
            c=np.asarray(d["c"]),
            nk=int(d["nk"]),
            y_rest=np.asarray(d["y_rest"]),
            info=dict(d.get("info", {})),
        )


def _as_2d(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    return x[:, None] if x.ndim == 1 else x


def lag_matrix(
    y: np.ndarray, u: np.ndarray, na: int, nb: int, nk: int
) -> tuple[np.ndarray, np.ndarray]:
    """Regressors ``[y_{t-1..t-na}, u_{t-nk..t-nk-nb+1}, 1]`` and targets ``y_t``.

    Rows start at the first frame whose lags all exist.
    """
    y, u = _as_2d(y), _as_2d(u)
    start = max(na, nk + nb - 1)
    n = len(y)
    rows = range(start, n)
    cols = [y[start - i : n - i] for i in range(1, na + 1)]
    cols += [u[start - nk - j : n - nk - j] for j in range(nb)]
    cols.append(np.ones((max(n - start, 0), 1)))
    return np.hstack(cols), y[rows.start :]


def fit_arx(
    y: np.ndarray, u: np.ndarray, *, na: int = 4, nb: int = 4, nk: int = 1, ridge: float = 0.0
) -> ArxModel:
    """Least-squares ARX fit of outputs ``y`` (n, n_out) on inputs ``u`` (n, n_in).

    ``ridge`` > 0 adds ``ridge * diag(X'X)`` to the normal equations (intercept excepted): a
    scale-free shrinkage that keeps short or collinear recordings from giving an explosive
    model. Raises ``ValueError`` when there are fewer equations than unknowns.
    """
    y, u = _as_2d(y), _as_2d(u)
    if len(y) != len(u):
        raise ValueError(f"y has {len(y)} frames, u has {len(u)}")
    x, target = lag_matrix(y, u, na, nb, nk)
    m, k = y.shape[1], u.shape[1]
    if x.shape[0] < x.shape[1]:
        raise ValueError(
            f"{x.shape[0]} equations for {x.shape[1]} unknowns per output: need a longer recording"
        )
    if ridge > 0:
        gram = x.T @ x
        pen = ridge * np.diag(np.diag(gram))
        pen[-1, -1] = 0.0
        theta = np.linalg.solve(gram + pen, x.T @ target)
    else:
        theta = np.linalg.lstsq(x, target, rcond=None)[0]
    a = theta[: na * m].T.reshape(m, na, m).transpose(1, 0, 2)
    b = theta[na * m : na * m + nb * k].T.reshape(m, nb, k).transpose(1, 0, 2)
    model = ArxModel(a=a, b=b, c=theta[-1], nk=nk, y_rest=y.mean(axis=0))
    resid = target - x @ theta
    model.info.update(
        frames=int(len(y)),
        ridge=float(ridge),
        one_step_rmse=np.sqrt(np.mean(resid**2, axis=0)).tolist(),
    )
    return model
