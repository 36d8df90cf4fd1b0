"""NDCCA gaze: closed-form CCA against scikit-learn, exact recovery of a kernel coupling; the
fixation model recovers known saccade intervals and offsets."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from sklearn.cross_decomposition import CCA

from app.stimuli.live.gaze import (
    FixationClock,
    cca,
    fit_fixation_model,
    fit_gaze_model,
    kernel,
    saccade_onsets,
)


def test_kernel_is_eq_10():
    np.testing.assert_allclose(kernel(np.array([-1.0, 0.0, 2.0])), [0.0, 0.0, 6.0])


def test_cca_matches_scikit_learn_canonical_correlations():
    rng = np.random.default_rng(0)
    n = 3000
    latent = rng.normal(size=(n, 2))
    x = np.column_stack(
        [
            latent[:, 0] + 0.5 * rng.normal(size=n),
            rng.normal(size=n),
            latent[:, 1] + rng.normal(size=n),
            rng.normal(size=n),
        ]
    )
    y = np.column_stack(
        [latent[:, 0] + 0.3 * rng.normal(size=n), latent[:, 1] + 0.8 * rng.normal(size=n)]
    )
    x, y = x - x.mean(0), y - y.mean(0)
    u, v, corr = cca(x, y)
    xs, ys = x @ u, y @ v
    np.testing.assert_allclose(np.var(xs, axis=0), 1.0, atol=1e-4)
    for i in range(2):
        assert np.corrcoef(xs[:, i], ys[:, i])[0, 1] == pytest.approx(corr[i], abs=1e-6)
    sk = CCA(n_components=2, max_iter=2000).fit(x, y)
    a, b = sk.transform(x, y)
    sk_corr = [abs(np.corrcoef(a[:, i], b[:, i])[0, 1]) for i in range(2)]
    np.testing.assert_allclose(corr, sk_corr, atol=2e-3)


def test_ndcca_reproduces_a_noise_free_kernel_coupling():
    # Gaze exactly linear in phi(standardised h): the NDCCA chain (eq. 13, 15 with
    # lambda = (1, 0)) must reproduce it on new frames.
    rng = np.random.default_rng(1)
    h = rng.normal(size=(2000, 4)) * [3.0, 2.0, 1.0, 0.5] + [1.0, 0.0, -1.0, 0.2]
    hz = (h - h.mean(0)) / h.std(0)
    mix = np.array([[1.0, 0.2], [-0.5, 0.7], [0.3, -0.4], [0.0, 0.9]])
    e = kernel(hz) @ mix + [2.0, -1.0]
    model = dataclasses.replace(fit_gaze_model(h, e), lambdas=(1.0, 0.0))
    np.testing.assert_allclose(model.correlations, 1.0, atol=1e-6)
    np.testing.assert_allclose(model.run(h[:50]), e[:50], atol=1e-6)


def test_smoothing_uses_the_fitted_transition(live_model):
    g = live_model.gaze
    h = np.column_stack([np.linspace(-5, 5, 30), np.zeros(30), np.zeros(30), np.ones(30)])
    out = g.run(h)
    coupling, prev = g.coupling(), np.zeros(g.r)
    for t in range(30):  # eq. 13-15 by hand
        phi = (kernel((h[t] - g.h_mean) / g.h_std) - g.phi_mean) / g.phi_std
        prev = 0.7 * (phi @ coupling) + 0.3 * (prev @ g.a_t)
        np.testing.assert_allclose(out[t], prev @ g.v_star * g.e_std + g.e_mean, atol=1e-12)


def test_a_gazeless_ground_truth_gives_a_disabled_model():
    model = fit_gaze_model(np.random.default_rng(0).normal(size=(100, 4)), np.zeros((100, 2)))
    assert not model.enabled
    np.testing.assert_array_equal(model.run(np.ones((3, 4))), np.zeros((3, 2)))


def test_fixation_model_recovers_known_saccades_and_offsets():
    # Fixations of 1.5 s (talking) and 3 s (listening) median, offsets N((2, -1), (5, 2)) and
    # N((0, 0), (3, 3)): the fitted intervals and offsets come back.
    rng = np.random.default_rng(3)
    fps, n = 30.0, 30 * 3000
    talking = (np.arange(n) // 1800) % 2 == 0  # 60 s talking, 60 s listening
    gaze = np.zeros((n, 2))
    t = 0
    while t < n:
        talk = bool(talking[t])
        mu = np.log(1.5 if talk else 3.0)
        length = max(int(np.exp(mu + 0.4 * rng.standard_normal()) * fps), 3)
        gaze[t : t + length] = rng.normal([2, -1], [5, 2]) if talk else rng.normal(0, 3, 2)
        t += length
    model, summary = fit_fixation_model(gaze, np.zeros((n, 2)), talking, fps)
    assert summary["interval_source"] == ["fitted", "fitted"]
    np.testing.assert_allclose(np.exp(model.intervals[:, 0]), [1.5, 3.0], rtol=0.15)
    np.testing.assert_allclose(model.offsets[0], [2, -1, 5, 2], atol=0.5)
    np.testing.assert_allclose(model.offsets[1, 2:], [3, 3], atol=0.5)


def test_saccade_onsets_are_where_the_speed_rises_through_the_threshold():
    gaze = np.zeros((10, 2))
    gaze[4:, 0] = 3.0  # 3 deg in one frame at 30 fps: 90 deg/s
    gaze[7:, 1] = 0.5  # 15 deg/s: a drift, not a saccade
    assert saccade_onsets(gaze, 30.0).tolist() == [4]
    assert saccade_onsets(gaze, 30.0, starts=(0, 4)).tolist() == []


def test_fixation_clock_holds_an_offset_between_saccades():
    clock = FixationClock(
        np.array([[0.0, 0.1], [0.0, 0.1]]),
        np.random.default_rng(0),
        offsets=np.array([[0, 0, 4, 4]] * 2, float),
    )
    offsets = np.array([clock.step(i / 30.0, True) for i in range(600)])
    changes = np.flatnonzero(np.any(np.diff(offsets, axis=0) != 0, axis=1))
    assert 12 <= len(changes) <= 28  # about one saccade a second over 20 s
    assert np.diff(changes).min() >= 15
