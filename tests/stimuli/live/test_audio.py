"""Causal audio features: known pitch and level of synthetic signals, block independence."""

from __future__ import annotations

import numpy as np
import pytest

from app.stimuli.live.audio import AudioFrameStream

SR = 16000


def _harmonic(f0: np.ndarray, amplitude: float = 0.2) -> np.ndarray:
    phase = 2 * np.pi * np.cumsum(f0) / SR
    x = sum(np.sin(k * phase) / k for k in range(1, 6))
    return amplitude * x / np.max(np.abs(x))


def test_pitch_of_a_harmonic_glide():
    t = np.arange(2 * SR) / SR
    f0 = 110 + 100 * t / 2  # 110 -> 210 Hz
    frames = AudioFrameStream(SR, 30.0).push(_harmonic(f0))
    est = np.array([f for f, _ in frames])
    times = np.arange(len(frames)) / 30.0
    window = 3 / 75.0  # a frame is analysed on the window ending at its time
    truth = 110 + 50 * (times - window / 2)
    ok = times > window
    assert np.all(est[ok] > 0)
    np.testing.assert_allclose(est[ok], truth[ok], atol=3.0)


@pytest.mark.parametrize("amplitude", [0.02, 0.2])
def test_intensity_of_a_sine_in_pascals(amplitude):
    t = np.arange(SR) / SR
    frames = AudioFrameStream(SR, 30.0).push(amplitude * np.sin(2 * np.pi * 200 * t))
    db = np.array([d for _, d in frames[5:]])
    want = 10 * np.log10(amplitude**2 / 2 / (2e-5) ** 2)  # rms^2 re 20 uPa
    np.testing.assert_allclose(db, want, atol=0.3)


def test_silence_and_noise_are_unvoiced():
    rng = np.random.default_rng(0)
    stream = AudioFrameStream(SR, 30.0)
    silent = stream.push(np.zeros(SR // 2))
    noisy = stream.push(0.05 * rng.normal(size=SR // 2))
    assert all(f == 0.0 for f, _ in silent) and all(d < 0 for _, d in silent)
    assert np.mean([f == 0.0 for f, _ in noisy]) > 0.9


def test_frames_do_not_depend_on_block_boundaries():
    rng = np.random.default_rng(1)
    x = _harmonic(np.full(SR, 150.0)) + 0.01 * rng.normal(size=SR)
    whole = AudioFrameStream(SR, 25.0).push(x)
    stream = AudioFrameStream(SR, 25.0)
    pieces = []
    for block in np.array_split(x, 77):
        pieces += stream.push(block)
    assert pieces == whole


def test_bad_settings():
    with pytest.raises(ValueError):
        AudioFrameStream(SR, 30.0, pitch_floor=600, pitch_ceiling=75)
