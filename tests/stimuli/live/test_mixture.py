"""Gaussian mixtures: EM recovers a known mixture; the per-frame slices are exact."""

from __future__ import annotations

import numpy as np
from scipy.stats import multivariate_normal

from app.stimuli.live.mixture import Mixture, MixtureBank, fit_mixture

TRUE = Mixture(
    weights=np.array([0.5, 0.3, 0.2]),
    means=np.array([[-4.0, 0.0, 1.0], [3.0, 3.0, -2.0], [2.0, -4.0, 4.0]]),
    covariances=np.array(
        [
            [[1.0, 0.5, 0.0], [0.5, 1.0, 0.2], [0.0, 0.2, 0.5]],
            [[0.6, -0.2, 0.1], [-0.2, 0.8, 0.0], [0.1, 0.0, 0.4]],
            [[0.3, 0.0, 0.0], [0.0, 0.5, 0.25], [0.0, 0.25, 1.0]],
        ]
    ),
)


def _sample(m: Mixture, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    k = rng.choice(m.n_components, size=n, p=m.weights)
    return np.stack([rng.multivariate_normal(m.means[i], m.covariances[i]) for i in k])


def test_em_recovers_a_known_mixture():
    x = _sample(TRUE, 6000, seed=0)
    fitted = fit_mixture(x, n_components=3, seed=0)
    order = [int(np.argmin(np.linalg.norm(fitted.means - mu, axis=1))) for mu in TRUE.means]
    assert sorted(order) == [0, 1, 2]
    np.testing.assert_allclose(fitted.weights[order], TRUE.weights, atol=0.02)
    np.testing.assert_allclose(fitted.means[order], TRUE.means, atol=0.08)
    np.testing.assert_allclose(fitted.covariances[order], TRUE.covariances, atol=0.08)


def test_log_density_matches_scipy():
    x = _sample(TRUE, 50, seed=1)
    want = np.log(
        sum(
            w * multivariate_normal(mu, c).pdf(x)
            for w, mu, c in zip(TRUE.weights, TRUE.means, TRUE.covariances, strict=True)
        )
    )
    np.testing.assert_allclose(TRUE.log_density(x), want, rtol=1e-10)


def test_marginal_and_padding_keep_the_density():
    x = _sample(TRUE, 40, seed=2)
    marg = TRUE.marginal([0, 2])
    want = np.log(
        sum(
            w * multivariate_normal(mu[[0, 2]], c[np.ix_([0, 2], [0, 2])]).pdf(x[:, [0, 2]])
            for w, mu, c in zip(TRUE.weights, TRUE.means, TRUE.covariances, strict=True)
        )
    )
    np.testing.assert_allclose(marg.log_density(x[:, [0, 2]]), want, rtol=1e-10)
    np.testing.assert_allclose(TRUE.padded(7).log_density(x), TRUE.log_density(x), rtol=1e-12)


def test_slice_coefficients_give_each_components_log_density():
    other = fit_mixture(_sample(TRUE, 500, seed=3), 2, seed=0)
    bank = MixtureBank.stack([TRUE, other])  # pads `other` to three components
    fixed = np.array([[0.7, -1.2], [0.1, 0.3]])
    a0, a1, a2 = bank.slice_coefficients(fixed)
    for g, m in enumerate((TRUE, other.padded(3))):
        for kappa in (-3.0, 0.0, 2.5):
            x = np.concatenate([[kappa], fixed[g]])
            poly = a0[g] + a1[g] * kappa + a2[g] * kappa**2
            total = np.log(np.exp(poly).sum())
            np.testing.assert_allclose(total, m.log_density(x)[0], rtol=1e-10)
            live = m.weights > 0
            comp = [
                np.log(m.weights[k]) + multivariate_normal(m.means[k], m.covariances[k]).logpdf(x)
                for k in np.flatnonzero(live)
            ]
            np.testing.assert_allclose(poly[live], comp, rtol=1e-10)
