"""The batched likelihood of :mod:`app.analysis.btd_likelihood`."""

import numpy as np
import pytest

from app.analysis.btd_likelihood import batched_terms, design_matrix, vote_cells


def _batch(seed, batch=4, n=3):
    rng = np.random.default_rng(seed)
    counts = rng.poisson(4.0, (batch, n, n, 3)).astype(float)
    off = ~np.eye(n, dtype=bool)
    x = design_matrix(n)[off]
    return vote_cells(counts, True), x, rng.normal(0, 0.5, (batch, n + 2))


@pytest.mark.parametrize("penalty", [True, False])
def test_gradient_and_hessian_match_finite_differences(penalty):
    cells, x, beta = _batch(1)
    nll, grad, hess = batched_terms(beta, cells, x, penalty=penalty)
    h, k = 1e-6, beta.shape[1]
    for q in range(k):
        step = np.zeros_like(beta)
        step[:, q] = h
        up, down = (batched_terms(beta + s, cells, x, penalty=penalty) for s in (step, -step))
        np.testing.assert_allclose((up[0] - down[0]) / (2 * h), grad[:, q], rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose((up[1] - down[1]) / (2 * h), hess[:, :, q], rtol=1e-5, atol=1e-5)


def test_the_objective_is_minus_the_multinomial_log_likelihood():
    cells, x, beta = _batch(2, batch=2)
    nll, _, _ = batched_terms(beta, cells, x, penalty=False)
    eta = np.einsum("cok,bk->bco", x, beta)
    log_p = eta - np.log(np.exp(eta).sum(axis=-1, keepdims=True))
    np.testing.assert_allclose(nll, -(cells * log_p).sum(axis=(1, 2)), rtol=1e-12)


def test_each_array_of_a_batch_is_taken_alone():
    cells, x, beta = _batch(3, batch=6)
    together = batched_terms(beta, cells, x)
    for b in range(6):
        alone = batched_terms(beta[b : b + 1], cells[b : b + 1], x)
        for whole, single in zip(together, alone, strict=True):
            np.testing.assert_allclose(whole[b], single[0], rtol=1e-12, atol=1e-12)


def test_without_ties_two_answers_are_modelled():
    rng = np.random.default_rng(4)
    counts = rng.poisson(3.0, (2, 3, 3, 3)).astype(float)
    x = design_matrix(3, ties=False)[~np.eye(3, dtype=bool)]
    cells = vote_cells(counts, False)
    assert cells.shape == (2, 6, 2) and x.shape == (6, 2, 4)
    nll, grad, hess = batched_terms(np.zeros((2, 4)), cells, x, penalty=False)
    np.testing.assert_allclose(nll, cells.sum(axis=(1, 2)) * np.log(2.0))
