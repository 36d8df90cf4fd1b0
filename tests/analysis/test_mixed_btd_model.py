"""The likelihood and solve of :mod:`app.analysis.mixed_btd_model`."""

import numpy as np
import pytest

from app.analysis.mixed_btd_model import MixedBTDModel
from app.analysis.mixed_coverage import Truth, simulate_counts


def _study(truth, participants, clips, seed):
    return simulate_counts(truth, participants, clips, np.random.default_rng(seed))


def test_derivatives_match_finite_differences():
    rng = np.random.default_rng(3)
    t = _study(Truth(), 5, 3, 1)
    model = MixedBTDModel(t)
    z = rng.normal(0, 0.3, model.m)
    b = rng.normal(0, 0.3, (model.P, model.n))
    at = model.terms(z, b)
    flat = np.concatenate([z, b.ravel()])

    def ll(x):
        return model.terms(x[: model.m], x[model.m :].reshape(b.shape))["ll"]

    h = 1e-5
    eye = np.eye(flat.size)
    grad = np.array([(ll(flat + h * e) - ll(flat - h * e)) / (2 * h) for e in eye])
    np.testing.assert_allclose(grad[: model.m], at["gz"], atol=1e-5)
    np.testing.assert_allclose(grad[model.m :], at["gb"].ravel(), atol=1e-5)

    def gradient(x):
        g = model.terms(x[: model.m], x[model.m :].reshape(b.shape))
        return np.concatenate([g["gz"], g["gb"].ravel()])

    hess = -np.array([(gradient(flat + h * e) - gradient(flat - h * e)) / (2 * h) for e in eye])
    m = model.m
    np.testing.assert_allclose(hess[:m, :m], at["C"], atol=1e-4)
    blocks = hess[m:, m:].reshape(model.P, model.n, model.P, model.n)
    for p in range(model.P):
        np.testing.assert_allclose(blocks[p, :, p, :], at["A"][p], atol=1e-4)
    np.testing.assert_allclose(hess[m:, :m].reshape(model.P, model.n, m), at["B"], atol=1e-4)


def test_terms_taken_a_chunk_at_a_time_are_those_of_one_pass(monkeypatch):
    import app.analysis.mixed_btd_model as module

    rng = np.random.default_rng(4)
    t = _study(Truth(), 9, 4, 2)
    whole = MixedBTDModel(t)
    z, b = rng.normal(0, 0.3, whole.m), rng.normal(0, 0.3, (whole.P, whole.n))
    at = whole.terms(z, b)
    monkeypatch.setattr(module, "CHUNK", 7)  # far from a divisor of the cells
    chunked = MixedBTDModel(t)
    assert len(chunked.total) > 5 * 7
    again = chunked.terms(z, b)
    assert again["ll"] == pytest.approx(at["ll"], rel=1e-12)
    for key in ("gz", "gb", "C", "A", "B"):
        np.testing.assert_allclose(again[key], at[key], rtol=1e-12, atol=1e-12)


def test_terms_in_the_models_own_arrays_are_those_made_anew_and_survive_the_other_slot():
    rng = np.random.default_rng(6)
    model = MixedBTDModel(_study(Truth(), 7, 3, 3))
    z, b = rng.normal(0, 0.3, model.m), rng.normal(0, 0.3, (model.P, model.n))
    fresh = model.terms(z, b)
    kept = model.terms(z, b, slot=0)
    for key in ("gz", "gb", "C", "A", "B"):
        np.testing.assert_array_equal(kept[key], fresh[key])
    model.terms(z + 0.1, b - 0.1, slot=1)  # a trial step beside it
    for key in ("gz", "gb", "C", "A", "B"):
        np.testing.assert_array_equal(kept[key], fresh[key])
