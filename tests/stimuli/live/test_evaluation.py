"""Held-out evaluation: the measures on signals with known answers, and the live model on speech
and motion it was not trained on (bands the generated motion must meet)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.stimuli.fap import DEG_PER_AU
from app.stimuli.live.corpus import TRAIN_VOICES, speech_take
from app.stimuli.live.evaluation import (
    CHANNELS,
    blink_rate,
    compare_motion,
    evaluate_held_out,
    held_out_split,
    high_frequency_fraction,
)
from app.stimuli.live.eyelids import blink_closure
from app.stimuli.live.model import train_live_model
from app.stimuli.speech import load_sound
from app.stimuli.track import MotionTrack


def test_high_frequency_fraction_of_known_mixtures():
    t = np.arange(600) / 30.0
    slow, fast = np.sin(2 * np.pi * 1.0 * t), np.sin(2 * np.pi * 6.0 * t)
    assert high_frequency_fraction(slow + fast, 30.0) == pytest.approx(0.5, abs=1e-9)
    assert high_frequency_fraction(slow + 0.5 * fast, 30.0) == pytest.approx(0.2, abs=1e-9)
    assert high_frequency_fraction(slow, 30.0) == pytest.approx(0.0, abs=1e-9)
    assert high_frequency_fraction(np.full(100, 3.0), 30.0) == 0.0


def test_blink_rate_counts_known_blinks():
    times = np.arange(1800) / 30.0  # one minute
    closure = sum(blink_closure(times - onset) for onset in (5.0, 21.0, 40.5, 52.0))
    track = MotionTrack.from_channels(
        30.0, {19: 819.2 * closure, 20: 819.2 * closure, 21: 204.8 * closure, 22: 204.8 * closure}
    )
    assert blink_rate(track) == pytest.approx(4.0)


def test_compare_motion_of_a_scaled_copy():
    rng = np.random.default_rng(0)
    cols = {c: np.cumsum(rng.normal(0, 50, 900)) for c in (48, 49, 50, 23, 24, 25, 26)}
    truth = MotionTrack.from_channels(30.0, cols)
    half = MotionTrack.from_channels(30.0, {c: 0.5 * v for c, v in cols.items()})
    fig = compare_motion(half, truth)
    np.testing.assert_allclose(fig.sd_ratio, 0.5)
    np.testing.assert_allclose(fig.correlation, 1.0)
    np.testing.assert_allclose(fig.jitter, fig.jitter_truth)
    assert fig.sd_truth[0] == pytest.approx(np.std(cols[48]) * DEG_PER_AU)
    assert len(fig.table().splitlines()) == len(CHANNELS) + 2


@pytest.fixture(scope="module")
def split():
    sound, _ = load_sound(Path(__file__).resolve().parents[3] / "app/data/demo/speech.wav")
    return held_out_split(sound, seconds=60.0, test_takes=2)  # 3 x 60 s to train, 2 x 60 s to test


def test_split_is_explicit_and_disjoint(split):
    train_seeds = {t.metadata["seed"] for _, t in split.train}
    test_seeds = {t.metadata["seed"] for _, t in split.test}
    assert train_seeds == {0, 1, 2} and test_seeds == {100, 101}
    train_voices = {tuple(v) for f, _ in split.train for v in f.metadata["voices"]}
    test_voices = {tuple(v) for f, _ in split.test for v in f.metadata["voices"]}
    assert not train_voices & test_voices
    assert all(f.n_frames == 1800 for f, _ in split.train + split.test)


def test_a_take_is_the_same_for_the_same_seed():
    """Praat's overlap-add draws random numbers in unvoiced stretches; unseeded, every take
    (and so every held-out figure) differed from run to run."""
    sound, _ = load_sound(Path(__file__).resolve().parents[3] / "app/data/demo/speech.wav")
    a, b = (speech_take(sound, TRAIN_VOICES[:1], 6.0, seed=4) for _ in range(2))
    np.testing.assert_array_equal(a.f0, b.f0)
    np.testing.assert_array_equal(a.intensity, b.intensity)
    other = speech_take(sound, TRAIN_VOICES[:1], 6.0, seed=5)
    assert not np.array_equal(a.intensity, other.intensity)


@pytest.mark.slow
def test_held_out_motion_moves_like_the_reference_speaker(split):
    # Trained on three takes, generated on two others (other voices, other motion seeds).
    model = train_live_model([f for f, _ in split.train], [t for _, t in split.train])
    fig = evaluate_held_out(model, split.test, seeds=(0, 1))  # one seed alone varies by 0.2
    head = slice(0, 3)
    # Measured (this split, two seeds): head sd 0.92-1.08 of the truth's; the share of the
    # variance above 4 Hz 0.45-0.93 of the truth's for head and gaze (without the low-pass on
    # the shown pose and the 0.1-s saccades: head roll 1.36, gaze yaw 3.36 and pitch 3.05).
    assert np.all((fig.sd_ratio[head] > 0.75) & (fig.sd_ratio[head] < 1.35)), fig.table()
    assert np.all(fig.jitter <= 1.25 * fig.jitter_truth), fig.table()
    assert np.all(fig.sd[3:] > 2.0) and np.all(fig.sd_ratio[3:] > 0.6), fig.table()
    assert 10.0 < fig.blinks_per_min < 30.0, fig.table()
