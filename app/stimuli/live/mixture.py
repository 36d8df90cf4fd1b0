"""Gaussian mixtures over (kinematic feature, speech features) and their per-frame 1-D slices.

Le, Ma & Deng 2012, sec. 5.1, eq. 2: for each head kinematic feature kappa a mixture of ``m``
full-covariance Gaussians models the joint density of ``X = (kappa, p, l)`` (pitch ``p``,
loudness ``l``); it is fitted by EM (scikit-learn's ``GaussianMixture``).

At synthesis time (sec. 5.2, eq. 3-4) the speech coordinates of ``X`` are fixed for the frame,
so each component's log density is a quadratic polynomial in the single free coordinate kappa:

    log c_k N(X; mu_k, Sigma_k) = a0_k + a1_k kappa + a2_k kappa^2.

:meth:`MixtureBank.slice_coefficients` computes ``(a0, a1, a2)`` once per frame for all five
mixtures at once; the gradient ascent then evaluates the mixture log density and its analytic
derivative with a handful of array operations per step (see :mod:`app.stimuli.live.head`).

Example
-------
>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> x = rng.normal(size=(500, 2))
>>> bank = MixtureBank.stack([fit_mixture(x, 2, seed=0), fit_mixture(x[:, ::-1], 2, seed=0)])
>>> a0, a1, a2 = bank.slice_coefficients(np.array([[0.0], [0.0]]))
>>> a0.shape
(2, 2)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from threadpoolctl import threadpool_limits

_LOG_2PI = float(np.log(2.0 * np.pi))


@dataclass(frozen=True)
class Mixture:
    """One Gaussian mixture: ``weights`` (K,), ``means`` (K, D), ``covariances`` (K, D, D)."""

    weights: np.ndarray
    means: np.ndarray
    covariances: np.ndarray

    @property
    def n_components(self) -> int:
        return len(self.weights)

    @property
    def dim(self) -> int:
        return self.means.shape[1]

    def log_density(self, x: np.ndarray) -> np.ndarray:
        """Log density at the rows of ``x`` (n, D) (eq. 2), for checks and training summaries."""
        x = np.atleast_2d(np.asarray(x, dtype=np.float64))
        prec = np.linalg.inv(self.covariances)
        _, logdet = np.linalg.slogdet(self.covariances)
        d = x[:, None, :] - self.means[None]  # (n, K, D)
        maha = np.einsum("nki,kij,nkj->nk", d, prec, d)
        with np.errstate(divide="ignore"):
            logw = np.log(self.weights)
        comp = logw - 0.5 * (self.dim * _LOG_2PI + logdet) - 0.5 * maha
        top = comp.max(axis=1, keepdims=True)
        return (top + np.log(np.exp(comp - top).sum(axis=1, keepdims=True)))[:, 0]

    def marginal(self, keep: list[int]) -> Mixture:
        """The mixture of the coordinates ``keep`` (a Gaussian mixture marginalises exactly)."""
        idx = np.asarray(keep)
        return Mixture(
            self.weights.copy(),
            self.means[:, idx].copy(),
            self.covariances[:, idx][:, :, idx].copy(),
        )

    def padded(self, n_components: int) -> Mixture:
        """Same density with zero-weight unit components appended up to ``n_components``."""
        extra = n_components - self.n_components
        if extra <= 0:
            return self
        d = self.dim
        return Mixture(
            np.concatenate([self.weights, np.zeros(extra)]),
            np.concatenate([self.means, np.zeros((extra, d))]),
            np.concatenate([self.covariances, np.broadcast_to(np.eye(d), (extra, d, d))]),
        )


def fit_mixture(
    x: np.ndarray,
    n_components: int = 10,
    *,
    seed: int = 0,
    reg_covar: float = 1e-4,
    max_iter: int = 300,
) -> Mixture:
    """Fit a full-covariance Gaussian mixture to the rows of ``x`` by EM (sec. 5.1).

    The number of components is reduced to ``len(x) // 15`` (at least 1) when there are too few
    samples to support ``n_components`` full covariances. ``reg_covar`` is added to each
    covariance's diagonal (the data are standardised, so it is relative to unit variance).

    EM runs with one BLAS thread: its matrices are 3 x 3, and a threaded BLAS spends more on
    waking its threads than on the arithmetic (a 100-s take trained in 3.7 s of CPU with two
    OpenBLAS threads on a busy two-core machine, 0.3 s with one; the fits are identical).
    """
    # scikit-learn only where a model is trained: generating from a trained one does without
    # it (its import was a third of a second of every `stimuli generate`)
    from sklearn.mixture import GaussianMixture

    x = np.asarray(x, dtype=np.float64)
    k = int(max(1, min(n_components, len(x) // 15)))
    gm = GaussianMixture(
        n_components=k,
        covariance_type="full",
        reg_covar=reg_covar,
        max_iter=max_iter,
        n_init=1,
        random_state=seed,
    )
    with threadpool_limits(limits=1, user_api="blas"):
        gm.fit(x)
    return Mixture(
        np.asarray(gm.weights_, dtype=np.float64),
        np.asarray(gm.means_, dtype=np.float64),
        np.asarray(gm.covariances_, dtype=np.float64),
    )


@dataclass(frozen=True)
class MixtureBank:
    """Several mixtures of one dimension ``D`` whose first coordinate is the free one.

    Precomputes, per mixture ``g`` and component ``k``, the pieces of the quadratic form that do
    not depend on the frame: the precision's free-free entry, its free-fixed row, its fixed-fixed
    block, and the constant ``log c_k - log|2 pi Sigma_k| / 2 - Lambda_00 mu_0^2 / 2``.
    """

    mixtures: tuple[Mixture, ...]
    lam00: np.ndarray  # (G, K)
    lam0r: np.ndarray  # (G, K, D-1)
    lamrr: np.ndarray  # (G, K, D-1, D-1)
    mu0: np.ndarray  # (G, K)
    mur: np.ndarray  # (G, K, D-1)
    const: np.ndarray  # (G, K)
    # the fixed coordinates' marginal (precision, log weight + normalising constant) and the
    # regression of the free coordinate on them: E[x0 | r] = mu0 + beta . (r - mu_r) per component
    marg_prec: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (G, K, D-1, D-1)
    marg_const: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (G, K)
    beta: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (G, K, D-1)

    @classmethod
    def stack(cls, mixtures: list[Mixture]) -> MixtureBank:
        """Stack mixtures (padding to a common component count) and precompute their pieces."""
        k = max(m.n_components for m in mixtures)
        padded = [m.padded(k) for m in mixtures]
        w = np.stack([m.weights for m in padded])
        mu = np.stack([m.means for m in padded])
        cov = np.stack([m.covariances for m in padded])
        prec = np.linalg.inv(cov)
        prec = 0.5 * (prec + np.swapaxes(prec, -1, -2))
        _, logdet_cov = np.linalg.slogdet(cov)
        d = mu.shape[-1]
        with np.errstate(divide="ignore"):
            logw = np.log(w)
        lam00 = prec[..., 0, 0]
        mu0 = mu[..., 0]
        const = logw - 0.5 * (d * _LOG_2PI + logdet_cov) - 0.5 * lam00 * mu0 * mu0
        cov_rr = cov[..., 1:, 1:]
        marg_prec = np.linalg.inv(cov_rr)
        marg_prec = 0.5 * (marg_prec + np.swapaxes(marg_prec, -1, -2))
        _, logdet_rr = np.linalg.slogdet(cov_rr)
        marg_const = logw - 0.5 * ((d - 1) * _LOG_2PI + logdet_rr)
        beta = np.einsum("gkij,gkj->gki", marg_prec, cov[..., 1:, 0])
        return cls(
            tuple(mixtures),
            lam00,
            prec[..., 0, 1:],
            prec[..., 1:, 1:],
            mu0,
            mu[..., 1:],
            const,
            marg_prec,
            marg_const,
            beta,
        )

    def slice_coefficients(self, fixed: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Coefficients ``(a0, a1, a2)``, each (G, K), of the components' log densities as
        quadratics in the free coordinate, with the other coordinates set to ``fixed`` (G, D-1).

        With ``d = fixed - mu_r``, ``B = Lambda_0r . d`` and ``C = d' Lambda_rr d``:
        ``a2 = -Lambda_00 / 2``, ``a1 = Lambda_00 mu_0 - B``,
        ``a0 = const + mu_0 B - C / 2``.
        """
        d = fixed[:, None, :] - self.mur  # (G, K, D-1)
        b = np.einsum("gki,gki->gk", self.lam0r, d)
        c = np.einsum("gki,gkij,gkj->gk", d, self.lamrr, d)
        return self.const + self.mu0 * b - 0.5 * c, self.lam00 * self.mu0 - b, -0.5 * self.lam00

    def conditional_mean(self, fixed: np.ndarray) -> np.ndarray:
        """The expectation of each mixture's free coordinate given the others (Gaussian mixture
        regression): ``fixed`` (G, D-1) -> (G,), or (n, G, D-1) -> (n, G) for n frames.

        ``E[x0 | r] = sum_k gamma_k(r) (mu0_k + beta_k . (r - mu_r,k))``, with ``gamma_k`` the
        components' responsibilities under the marginal of ``r`` and ``beta_k`` the regression
        coefficients of ``Sigma_k`` (zero-weight components get no responsibility).
        """
        d = fixed[..., None, :] - self.mur  # (..., G, K, D-1)
        maha = np.einsum("...gki,gkij,...gkj->...gk", d, self.marg_prec, d)
        logp = self.marg_const - 0.5 * maha
        logp = logp - logp.max(axis=-1, keepdims=True)
        w = np.exp(logp)
        means = self.mu0 + np.einsum("gki,...gki->...gk", self.beta, d)
        return (w * means).sum(axis=-1) / w.sum(axis=-1)
