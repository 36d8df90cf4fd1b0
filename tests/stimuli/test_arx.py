import numpy as np
import pytest

from app.stimuli.arx import ArxModel, fit_arx, lag_matrix


def known_system(n_out=3, n_in=5, na=4, nb=4, nk=1, seed=0):
    rng = np.random.default_rng(seed)
    a = np.zeros((na, n_out, n_out))
    a[0] = 0.5 * np.eye(n_out) + 0.05 * rng.standard_normal((n_out, n_out))
    a[1] = -0.2 * np.eye(n_out)
    for i in range(2, na):
        a[i] = 0.05 * rng.standard_normal((n_out, n_out))
    b = rng.standard_normal((nb, n_out, n_in))
    model = ArxModel(a=a, b=b, c=rng.standard_normal(n_out), nk=nk)
    assert model.spectral_radius() < 0.95
    return model


@pytest.mark.parametrize("nk", [1, 2])
def test_fit_recovers_a_known_arx_system(nk):
    truth = known_system(nk=nk)
    rng = np.random.default_rng(1)
    u = rng.standard_normal((6000, 5))
    y = truth.simulate(u, noise=0.05 * rng.standard_normal((6000, 3)))
    fit = fit_arx(y, u, na=4, nb=4, nk=nk)
    np.testing.assert_allclose(fit.a, truth.a, atol=0.01)
    np.testing.assert_allclose(fit.b, truth.b, atol=0.01)
    np.testing.assert_allclose(fit.c, truth.c, atol=0.02)
    # run free from the inputs alone, the fitted model reproduces the noise-free output
    clean = truth.simulate(u)
    free = fit.simulate(u)
    assert np.sqrt(np.mean((free - clean) ** 2)) < 0.02 * clean.std()


def test_noise_free_fit_is_exact():
    truth = known_system(n_out=2, n_in=1, na=2, nb=3)
    u = np.random.default_rng(2).standard_normal((400, 1))
    fit = fit_arx(truth.simulate(u), u, na=2, nb=3, nk=1)
    np.testing.assert_allclose(fit.a, truth.a, atol=1e-9)
    np.testing.assert_allclose(fit.b, truth.b, atol=1e-9)


def test_lag_matrix_layout():
    y = np.arange(10.0)[:, None]
    u = 100 + np.arange(10.0)[:, None]
    x, target = lag_matrix(y, u, na=2, nb=2, nk=1)
    assert x.shape == (8, 5) and target[0, 0] == 2
    assert x[0].tolist() == [1, 0, 101, 100, 1]


def test_one_step_prediction_and_round_trip():
    truth = known_system(n_out=2, n_in=2)
    u = np.random.default_rng(3).standard_normal((200, 2))
    y = truth.simulate(u)
    np.testing.assert_allclose(truth.predict_one_step(y, u), y, atol=1e-9)
    again = ArxModel.from_dict(truth.to_dict())
    np.testing.assert_array_equal(again.a, truth.a)
    np.testing.assert_array_equal(again.simulate(u), y)


def test_ridge_shrinks_and_too_short_refuses():
    truth = known_system(n_out=1, n_in=1, na=2, nb=2)
    u = np.random.default_rng(4).standard_normal((500, 1))
    y = truth.simulate(u)
    plain, ridged = fit_arx(y, u, na=2, nb=2), fit_arx(y, u, na=2, nb=2, ridge=1.0)
    assert np.abs(ridged.b).sum() < np.abs(plain.b).sum()
    with pytest.raises(ValueError, match="equations"):
        fit_arx(y[:6], u[:6], na=4, nb=4)
