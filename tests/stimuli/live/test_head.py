"""Head model: eq. 1 features, the analytic gradient of eq. 4 against finite differences, and
the Langevin steps sampling exp(J)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from app.stimuli.live.head import HeadModel, fit_head_model, kinematic_features


def test_kinematic_features_known_values():
    angles = np.array([[0.0, 0.0, 0.0], [3.0, 4.0, 0.0], [6.0, 8.0, 12.0]])
    k = kinematic_features(angles, fps=10.0)
    np.testing.assert_allclose(k[:, :3], angles)
    assert np.isnan(k[0, 3]) and np.isnan(k[:2, 4]).all()
    np.testing.assert_allclose(k[1:, 3], [50.0, 130.0])  # 10 * |(3,4,0)|, 10 * |(3,4,12)|
    np.testing.assert_allclose(k[2, 4], 1200.0)  # 100 * |(0,0,12)|


@pytest.fixture(scope="module")
def head(live_model) -> HeadModel:
    return live_model.head


@pytest.mark.parametrize("pitch_z", [0.4, -1.1, np.nan])  # voiced and unvoiced frames
def test_analytic_gradient_matches_finite_differences(head, pitch_z):
    rng = np.random.default_rng(5)
    coeffs = head.frame_coefficients(pitch_z, 0.3)
    for _ in range(5):
        prev2 = head.kin_mean[:3] + rng.normal(0, 2, 3)
        prev1 = prev2 + rng.normal(0, 0.3, 3)
        theta = prev1 + rng.normal(0, 0.3, 3)
        _, grad = head.objective(theta, prev1, prev2, 30.0, coeffs)
        h = 1e-6
        fd = np.empty(3)
        for i in range(3):
            e = np.zeros(3)
            e[i] = h
            fd[i] = (
                head.objective(theta + e, prev1, prev2, 30.0, coeffs)[0]
                - head.objective(theta - e, prev1, prev2, 30.0, coeffs)[0]
            ) / (2 * h)
        np.testing.assert_allclose(grad, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def test_objective_is_the_weighted_sum_of_mixture_log_densities(head):
    prev2, prev1, theta = np.zeros(3), np.array([0.1, 0.0, 0.0]), np.array([0.3, -0.2, 0.1])
    f, _ = head.objective(theta, prev1, prev2, 30.0, head.frame_coefficients(0.5, -0.2))
    kin = kinematic_features(np.stack([prev2, prev1, theta]), 30.0)[2]
    z = (kin - head.kin_mean) / head.kin_std
    want = sum(
        w * m.log_density(np.array([z[g], 0.5, -0.2]))[0]
        for g, (w, m) in enumerate(zip(head.weights, head.voiced.mixtures, strict=True))
    )
    assert f == pytest.approx(want, rel=1e-9)


@pytest.mark.slow
def test_langevin_steps_sample_the_objective_s_distribution():
    # One Gaussian component per angle, dynamic terms off: exp(J) is a known normal per axis,
    # so the frame's pose must be distributed as that normal whatever the start.
    rng = np.random.default_rng(0)
    n = 6000
    pz, lz = rng.normal(0, 1, n), rng.normal(0, 1, n)
    angles = np.column_stack(
        [2 + 1.5 * rng.normal(0, 1, n), 3 * pz + rng.normal(0, 0.5, n), rng.normal(0, 0.8, n)]
    )
    model = fit_head_model(angles, pz, lz, 30.0, n_components=1, weights=[1, 1, 1, 0, 0])
    # Proposal variances about half the target's per axis, so that 60 steps mix well.
    model = replace(model, n_iter=60, proposal=1.0, step_std=30.0 * np.array([1.0, 0.35, 0.55]))
    coeffs = model.frame_coefficients(1.0, 0.0)  # pitch angle | pz = 1: N(3, 0.5^2)
    draws = np.array(
        [
            model.sample(np.zeros(3), np.zeros(3), np.zeros(3), 30.0, coeffs, rng)
            for _ in range(3000)
        ]
    )
    np.testing.assert_allclose(draws.mean(axis=0), [2.0, 3.0, 0.0], atol=0.1)
    np.testing.assert_allclose(draws.std(axis=0), [1.5, 0.5, 0.8], rtol=0.1)


def test_sampling_is_reproducible_for_a_generator_state(head):
    coeffs = head.frame_coefficients(0.2, 0.5)
    prev = head.kin_mean[:3]
    a = head.sample(prev, prev, prev, 30.0, coeffs, np.random.default_rng(9))
    b = head.sample(prev, prev, prev, 30.0, coeffs, np.random.default_rng(9))
    np.testing.assert_array_equal(a, b)


def test_pose_follows_the_speech_the_model_was_trained_on():
    # Pitch angle = 5 * standardised pitch: the draws should centre on it for each pitch.
    rng = np.random.default_rng(0)
    n = 4000
    pz = np.sin(np.arange(n) / 40.0) + rng.normal(0, 0.05, n)
    lz = rng.normal(0, 1, n)
    angles = np.column_stack(
        [rng.normal(0, 0.2, n).cumsum() * 0.01, 5 * pz, np.zeros(n) + rng.normal(0, 0.05, n)]
    )
    model = fit_head_model(angles, pz, lz, 30.0, n_components=4, weights=[1, 1, 1, 0, 0])
    for target in (-0.8, 0.0, 0.8):
        coeffs = model.frame_coefficients(target, 0.0)
        pose = np.array([0.0, 0.0, 0.0])
        poses = []
        for _ in range(300):  # frames at the same speech input
            pose = model.sample(pose, pose, pose, 30.0, coeffs, rng)
            poses.append(pose[1])
        assert np.mean(poses[100:]) == pytest.approx(5 * target, abs=0.6)
