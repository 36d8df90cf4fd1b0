"""Speech input scaling and the causal talking/listening mode."""

from __future__ import annotations

import numpy as np

from app.stimuli.live.inputs import SpeechScale, loudness, semitones, talking_mode


def test_semitones_and_unvoiced():
    st = semitones(np.array([100.0, 200.0, 50.0, 0.0]))
    np.testing.assert_allclose(st[:3], [0.0, 12.0, -12.0])
    assert np.isnan(st[3])


def test_loudness_floor():
    np.testing.assert_array_equal(loudness(np.array([-300.0, np.nan, 55.0])), [0.0, 0.0, 55.0])


def test_scale_from_training_frames():
    f0 = np.array([100.0, 200.0, 0.0, 0.0])
    scale = SpeechScale.fit(f0, np.array([60.0, 70.0, -300.0, 30.0]))
    assert scale.pitch_mean == 6.0 and scale.pitch_std == 6.0
    assert scale.loud_mean == 40.0  # -300 dB counted as 0 dB
    assert scale.threshold_db == 45.0  # median voiced loudness 65 dB - 20 dB
    np.testing.assert_allclose(scale.pitch_z(f0)[:2], [-1.0, 1.0])
    assert SpeechScale.from_array(scale.to_array()) == scale


def test_talking_mode_holds_for_the_window_after_loud_frames():
    loud = np.array([0, 60, 0, 0, 0, 0, 60, 0, 0], dtype=float)
    mode = talking_mode(loud, 50.0, fps=10.0, window_s=0.3)
    assert mode.tolist() == [False, True, True, True, False, False, True, True, True]
