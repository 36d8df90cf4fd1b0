"""The live head follows the speech (known answers): the GMMs' conditional expectation, the
alignment and variation of :mod:`app.stimuli.live.expectation`, the per-speaker normalisation,
and held-out generation against known couplings. Before the expectation synthesis the
generated head was a random walk: on the known couplings below its correlation with the
held-out truth was 0.08 / -0.01 / -0.05 (pitch / yaw / roll)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from app.stimuli.live.expectation import (
    PoseTracker,
    SpeechPose,
    ar2_at_rate,
    ar2_variance,
    expectations,
    fit_speech_pose,
    frame_expectation,
)
from app.stimuli.live.head import fit_head_model
from app.stimuli.live.inputs import SpeakerNorm, SpeechScale, speaker_normalised
from app.stimuli.live.mixture import Mixture, MixtureBank
from app.stimuli.live.model import train_live_model
from app.stimuli.live.stream import generate_track


def test_conditional_mean_of_one_gaussian_is_the_regression_line():
    cov = np.array([[4.0, 1.2, -0.6], [1.2, 1.0, 0.1], [-0.6, 0.1, 0.5]])
    mu = np.array([1.0, -0.5, 2.0])
    bank = MixtureBank.stack([Mixture(np.ones(1), mu[None], cov[None])])
    r = np.array([[0.3, 1.1], [-2.0, 2.5], [1.0, 0.0]])
    want = mu[0] + (r - mu[1:]) @ np.linalg.solve(cov[1:, 1:], cov[1:, 0])
    got = bank.conditional_mean(r[:, None, :])[:, 0]
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert bank.conditional_mean(r[0][None])[0] == pytest.approx(want[0], rel=1e-12)


def test_conditional_mean_of_a_mixture_matches_numerical_integration():
    means = np.array([[-2.0, -1.0], [3.0, 1.5]])
    covs = np.array([[[1.0, 0.5], [0.5, 1.0]], [[0.5, -0.2], [-0.2, 0.8]]])
    mix = Mixture(np.array([0.3, 0.7]), means, covs)
    bank = MixtureBank.stack([mix])
    x0 = np.linspace(-15, 15, 6001)
    for r in (-2.0, 0.0, 0.4, 1.2, 3.0):
        dens = np.exp(mix.log_density(np.column_stack([x0, np.full_like(x0, r)])))
        want = np.sum(x0 * dens) / np.sum(dens)
        assert bank.conditional_mean(np.array([[r]]))[0] == pytest.approx(want, abs=1e-6)


def test_the_expectation_follows_the_conditioning_input():
    # Pitch angle = 5 x standardised pitch (+ noise), yaw = -3 x loudness: the angle mixtures'
    # expectation must give those lines back, voiced and unvoiced.
    rng = np.random.default_rng(0)
    n = 6000
    pz = rng.normal(0, 1, n)
    lz = rng.normal(0, 1, n)
    pz[rng.random(n) < 0.3] = np.nan
    angles = np.column_stack(
        [
            -3 * lz + rng.normal(0, 0.3, n),
            5 * np.nan_to_num(pz) + rng.normal(0, 0.3, n),
            np.zeros(n),
        ]
    )
    angles[:, 2] = rng.normal(0, 0.5, n)
    head = fit_head_model(angles, pz, lz, 30.0, n_components=4, seed=0)
    grid = np.linspace(-1.5, 1.5, 7)
    e = expectations(head, grid, np.zeros(7))
    np.testing.assert_allclose(e[:, 1], 5 * grid, atol=0.35)
    e = expectations(head, np.full(7, np.nan), grid)
    np.testing.assert_allclose(e[:, 0], -3 * grid, atol=0.35)
    np.testing.assert_allclose(
        frame_expectation(head, 0.8, -0.5), expectations(head, [0.8], [-0.5])[0]
    )


def _low_pass(x, tau, fps=30.0):
    k = 1 - np.exp(-1 / (tau * fps))
    return signal.lfilter([k], [1, -(1 - k)], x)


def test_alignment_finds_a_known_lag_and_the_variation_the_rest():
    # The head follows 4 x pitch through a 0.3-s low-pass; the rest is an AR(1) of known sd.
    rng = np.random.default_rng(1)
    n = 9000
    pz = signal.lfilter([0.05], [1, -0.95], rng.normal(0, 1, n)) * 3
    lz = rng.normal(0, 1, n)
    ar = signal.lfilter([1], [1, -0.97], rng.normal(0, 0.2, n))  # sd 0.2 / sqrt(1 - 0.97^2)
    pitch = _low_pass(4 * pz, 0.3) + ar
    angles = np.column_stack([rng.normal(0, 1, n), pitch, rng.normal(0, 1, n)])
    head = fit_head_model(angles, pz, lz, 30.0, n_components=3, seed=0)
    pose, summary = fit_speech_pose(head, angles, pz, lz, 30.0)
    assert pose.tau_s[1] == pytest.approx(0.3)
    assert summary["speech_r2"][1] > 0.7 and summary["speech_r2"][0] < 0.05
    assert pose.variation_sd()[1] == pytest.approx(ar.std(), rel=0.15)
    assert pose.variation_sd()[0] == pytest.approx(1.0, rel=0.1)  # all variation: no speech


def test_the_variation_keeps_its_variance_at_another_frame_rate():
    a1, a2, sd = ar2_at_rate(0.9, 0.0, 0.1, 30.0, 60.0)
    assert a1 == pytest.approx(0.9**0.5) and a2 == pytest.approx(0.0, abs=1e-12)
    assert ar2_variance(a1, a2, sd) == pytest.approx(ar2_variance(0.9, 0.0, 0.1))
    b1, b2, sd2 = ar2_at_rate(1.6, -0.7, 0.3, 30.0, 24.0)  # complex roots
    assert ar2_variance(b1, b2, sd2) == pytest.approx(ar2_variance(1.6, -0.7, 0.3))
    pose = SpeechPose(
        np.zeros(3), np.ones(3), np.zeros(3), np.tile([1.6, -0.7], (3, 1)), np.full(3, 0.3), 30.0
    )
    for fps in (30.0, 60.0):
        tracker = PoseTracker(pose, np.zeros(3), fps, np.random.default_rng(0))
        draws = np.array([tracker.step(np.zeros(3)) for _ in range(int(400 * fps))])
        assert draws.std(axis=0) == pytest.approx(pose.variation_sd(), rel=0.1)


def test_per_speaker_normalisation_takes_a_voice_to_its_own_scale():
    # A voice 8 semitones above the training voices and 10 dB louder: after 40 s its features
    # are those of the same speech at the training level (the training scale alone reads it
    # as constantly high and loud).
    rng = np.random.default_rng(2)
    n = 2700
    pitch = 4 + 2 * np.sin(np.arange(n) / 13.0) + rng.normal(0, 0.3, n)
    pitch[rng.random(n) < 0.4] = np.nan
    loud = 60 + 6 * np.sin(np.arange(n) / 7.0) + rng.normal(0, 1, n)
    scale = SpeechScale.fit_contours(pitch, loud)
    base = speaker_normalised(pitch, loud, scale, 30.0)
    moved = speaker_normalised(pitch + 8, loud + 10, scale, 30.0)
    late = slice(1200, None)
    voiced = np.isfinite(pitch[late])
    np.testing.assert_allclose(moved[0][late][voiced], base[0][late][voiced], atol=0.3)
    np.testing.assert_allclose(moved[1][late], base[1][late], atol=0.06)
    assert np.nanmean(scale.pitch_z(pitch[late] + 8)) > 3  # what the training scale says
    norm = SpeakerNorm(scale, 30.0)
    streamed = np.array([norm.step(p, lo) for p, lo in zip(pitch + 8, loud + 10, strict=True)])
    np.testing.assert_array_equal(streamed[:, 1], moved[1])


def test_the_generated_head_follows_known_couplings_on_held_out_speech(
    live_training_data, live_held_out_speech
):
    """The conftest speaker's head pitch follows F0 and its yaw loudness (plus noise): on speech
    the model never saw, the generated head correlates with what that speaker would do."""
    from tests.stimuli.conftest import live_synthetic_speaker

    model = train_live_model(*live_training_data)
    held_speech, held_truth = live_synthetic_speaker(3000, 30.0, seed=7)
    r = np.mean(
        [
            [
                np.corrcoef(generate_track(model, held_speech, seed=s)[c], held_truth[c])[0, 1]
                for c in (48, 49, 50)
            ]
            for s in (0, 1)
        ],
        axis=0,
    )
    # measured 0.79 / 0.96 / 0.62 (the Langevin draw: 0.08 / -0.01 / -0.05)
    assert r[0] > 0.5 and r[1] > 0.8 and r[2] > 0.4, r
