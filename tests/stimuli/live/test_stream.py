"""The streaming generator: streaming == offline, causal, seeded; blinks follow the fitted
log-normals per mode; head motion beats the random condition on held-out reference speech."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from app.stimuli.live.condition import DEFAULT_MODEL_PATH
from app.stimuli.live.eyelids import BLINK_SHAPE, blink_onsets, closure_from_faps
from app.stimuli.live.modelfile import load_model
from app.stimuli.live.stream import OUTPUT_CHANNELS, LiveGenerator, generate_track
from app.stimuli.speech import SpeechFeatures


@pytest.fixture(scope="module")
def speech(live_training_data) -> SpeechFeatures:
    return live_training_data[0].slice(0, 400)


def test_streaming_frames_equal_offline_frames(live_model, speech):
    offline = generate_track(live_model, speech, seed=11)
    assert offline.channels == OUTPUT_CHANNELS == (19, 20, 21, 22, 23, 24, 25, 26, 48, 49, 50)
    gen = LiveGenerator(live_model, fps=speech.fps, seed=11)
    for t in range(speech.n_frames):
        frame = gen.step(float(speech.f0[t]), float(speech.intensity[t]))
        np.testing.assert_array_equal(frame, offline.values[t])


def test_frames_use_only_past_and_current_input(live_model, speech):
    full = generate_track(live_model, speech, seed=2).values
    changed = SpeechFeatures(
        speech.fps, speech.f0.copy(), speech.intensity.copy(), speech.f0_conditioned.copy()
    )
    changed.f0[200:] = 0.0
    changed.intensity[200:] = 10.0
    other = generate_track(live_model, changed, seed=2).values
    np.testing.assert_array_equal(other[:200], full[:200])
    assert not np.array_equal(other[200:], full[200:])


def test_same_seed_same_frames_other_seed_other_frames(live_model, speech):
    a = generate_track(live_model, speech, seed=5)
    assert a.equals(generate_track(live_model, speech, seed=5))
    assert not np.allclose(a[48], generate_track(live_model, speech, seed=6)[48])
    assert np.all(np.isfinite(a.values))


@functools.cache
def _default_model():
    return load_model(DEFAULT_MODEL_PATH)


_readings = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.just(0.0))


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(_readings, _readings), min_size=1, max_size=12))
def test_any_feature_values_give_finite_frames(frames):
    # NaN, infinite, negative, huge: no exception, and every FAP value is a number.
    gen = LiveGenerator(_default_model(), seed=0)
    for f0, intensity in frames:
        assert np.all(np.isfinite(gen.step(f0, intensity)))


def test_audio_blocks_of_any_size_give_the_same_frames(live_model):
    sr = 16000
    rng = np.random.default_rng(0)
    t = np.arange(3 * sr) / sr
    f0 = 140 + 30 * np.sin(2 * np.pi * 0.7 * t)
    voice = 0.2 * np.sin(2 * np.pi * np.cumsum(f0) / sr) * (np.sin(2 * np.pi * 1.5 * t) > -0.2)
    audio = voice + 0.001 * rng.normal(size=len(t))
    whole = LiveGenerator(live_model, seed=3).push_audio(audio, sr)
    assert len(whole) == 91  # frames at 0, 1/30, ..., 90/30 s: each needs samples before it
    gen = LiveGenerator(live_model, seed=3)
    cuts = np.sort(rng.choice(len(audio), 40, replace=False))
    blocks = np.split(audio, cuts)
    streamed = np.vstack([gen.push_audio(b, sr) for b in blocks])
    np.testing.assert_array_equal(streamed, whole)


@pytest.mark.slow
def test_blink_intervals_follow_the_fitted_log_normals(live_model):
    fps, block = 30.0, 600  # 20 s talking, 20 s listening, alternating
    n = 12000
    talk = (np.arange(n) // block) % 2 == 0
    f0 = np.where(talk, 130.0, 0.0)
    intensity = np.where(talk, 66.0, 20.0)
    features = SpeechFeatures(fps, f0, intensity, np.full(n, 130.0))
    gen = LiveGenerator(live_model, fps=fps, seed=8)
    values = gen.run(features.f0, features.intensity)
    log = np.array(gen.blink_log)
    # Onsets seen in the eyelid FAPs match the generator's onsets (half closed within Tc).
    closure, _ = closure_from_faps(values[:, :4])
    seen = blink_onsets(closure) / fps
    logged = log[log[:, 0] < (n - 1) / fps - BLINK_SHAPE[0], 0]
    assert len(seen) == len(logged)
    assert np.all((seen - logged >= 0) & (seen - logged <= BLINK_SHAPE[0] + 1 / fps))
    gaps, mode = np.diff(seen), log[: len(seen) - 1, 1].astype(bool)
    for i, sel in enumerate((mode, ~mode)):
        mu, sigma = live_model.eyelids.blink[i]
        assert sel.sum() >= 40
        fitted = stats.lognorm(s=sigma, scale=np.exp(mu))
        assert stats.kstest(gaps[sel], fitted.cdf).pvalue > 0.01
    # The two modes really differ here (known: talking median 1.8 s, listening 3.7 s).
    assert np.median(gaps[mode]) < np.median(gaps[~mode])


def _gazeless_model(live_training_data):
    from app.stimuli.live.model import train_live_model

    features, truth = live_training_data
    return train_live_model(
        features.slice(0, 300), truth.select((48, 49, 50)).fit_length(300), n_components=2
    )


@pytest.mark.parametrize("fps", [30.0, 60.0])
def test_a_saccade_takes_a_tenth_of_a_second_at_any_frame_rate(live_training_data, fps):
    """A fixation offset that jumps by 6 deg at 1 s: the eyes get there over 0.1 s (3 frames at
    30 fps, 6 at 60), not in the one frame that put a jitter into the gaze."""
    model = _gazeless_model(live_training_data)
    assert not model.gaze.enabled  # the gaze is the fixation offset alone
    gen = LiveGenerator(model, fps=fps, seed=0)
    gen._fixations.step = lambda time, talking: np.array([6.0 if time >= 1.0 - 1e-9 else 0.0, 0])
    n = int(1.5 * fps)
    yaw = gen.run(np.full(n, 120.0), np.full(n, 65.0))[:, OUTPUT_CHANNELS.index(23)] * 1e-5
    yaw = np.degrees(yaw)
    k, steps = int(fps), round(0.1 * fps)
    np.testing.assert_allclose(yaw[:k], 0.0, atol=1e-9)
    np.testing.assert_allclose(yaw[k : k + steps], 6.0 * np.arange(1, steps + 1) / steps)
    np.testing.assert_allclose(yaw[k + steps :], 6.0)


@pytest.mark.parametrize("synthesis", ["expectation", "langevin"])
@pytest.mark.parametrize("fps", [30.0, 60.0])
def test_the_shown_pose_is_the_draws_low_passed_in_time(
    live_training_data, fps, synthesis, monkeypatch
):
    """Poses that step from rest to rest + 1 deg at 1 s: the shown pose follows
    1 - exp(-t / 0.02 s) whatever the frame rate, and the Langevin sampler still sees the draws."""
    from app.stimuli.live.expectation import PoseTracker
    from app.stimuli.live.head import HeadModel

    model = _gazeless_model(live_training_data)
    rest = model.head.kin_mean[:3]
    gen = LiveGenerator(model, fps=fps, seed=0, synthesis=synthesis)
    seen = []

    def draw(self, start, prev1, prev2, fps_, coeffs, rng):
        seen.append(prev1.copy())
        return rest + (1.0 if gen.frame >= fps else 0.0)

    monkeypatch.setattr(HeadModel, "sample", draw)
    monkeypatch.setattr(
        PoseTracker, "step", lambda self, e: rest + (1.0 if gen.frame >= fps else 0.0)
    )
    n = int(1.2 * fps)
    pitch = gen.run(np.full(n, 120.0), np.full(n, 65.0))[:, OUTPUT_CHANNELS.index(48)]
    pitch = np.degrees(pitch * 1e-5) - rest[1]
    t = (np.arange(n) - fps + 1) / fps  # 1 / fps at the first frame of the step
    want = np.where(t > 0, 1.0 - np.exp(-t / 0.02), 0.0)
    np.testing.assert_allclose(pitch, want, atol=1e-9)
    if synthesis == "langevin":
        np.testing.assert_allclose(seen[int(fps) + 1], rest + 1.0)  # the draw, not the shown pose
