"""Speech input: the 3-frame contour smoothing, scaling and the causal talking mode."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from app.stimuli.live.inputs import (
    ContourSmoother,
    SpeechScale,
    loudness,
    semitones,
    smooth_contour,
    smooth_frames,
    smoothed_inputs,
    talking_mode,
)


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
    np.testing.assert_allclose(scale.pitch_z(semitones(f0))[:2], [-1.0, 1.0])
    assert SpeechScale.from_array(scale.to_array()) == scale


def test_talking_mode_holds_for_the_window_after_loud_frames():
    loud = np.array([0, 60, 0, 0, 0, 0, 60, 0, 0], dtype=float)
    mode = talking_mode(loud, 50.0, fps=10.0, window_s=0.3)
    assert mode.tolist() == [False, True, True, True, False, False, True, True, True]


def test_smoothing_a_step_gives_the_three_frame_ramp():
    step = np.r_[np.zeros(4), np.full(4, 30.0)]
    np.testing.assert_allclose(smooth_contour(step, 3), [0, 0, 0, 0, 10, 20, 30, 30])


def test_the_smoothing_window_is_0125_s_at_any_frame_rate():
    """L sec. 4: 3 frames at the paper's 24 fps are 0.125 s; 3 frames at 30 fps were 0.1 s."""
    assert [smooth_frames(f) for f in (24.0, 25.0, 30.0, 60.0)] == [3, 3, 4, 8]
    step = np.r_[np.full(4, 100.0), np.full(6, 200.0)]  # 0 -> 12 semitones
    pitch, _ = smoothed_inputs(step, np.full(10, 60.0), 30.0)
    np.testing.assert_allclose(pitch[3:9], [0, 3, 6, 9, 12, 12])  # a 4-frame ramp
    pitch24, _ = smoothed_inputs(step, np.full(10, 60.0), 24.0)
    np.testing.assert_allclose(pitch24[3:8], [0, 4, 8, 12, 12])


def test_smoothing_is_causal_and_skips_unvoiced_frames():
    st_ = np.array([3.0, np.nan, 6.0, 9.0, np.nan, np.nan, np.nan, 12.0])
    out = smooth_contour(st_, 3)
    np.testing.assert_allclose(out[[0, 2, 3, 7]], [3.0, 4.5, 7.5, 12.0])
    assert np.isnan(out[[1, 4, 5, 6]]).all()  # unvoiced stays unvoiced
    changed = st_.copy()
    changed[5:] = 40.0
    np.testing.assert_array_equal(smooth_contour(changed, 3)[:5], out[:5])


def test_smoothed_inputs_floor_loudness_and_convert_pitch():
    pitch, loud = smoothed_inputs(
        np.array([100.0, 200.0, 0.0]), np.array([-300.0, 30.0, 60.0]), 24.0
    )
    np.testing.assert_allclose(pitch[:2], [0.0, 6.0])
    np.testing.assert_allclose(loud, [0.0, 15.0, 30.0])


@given(st.lists(st.one_of(st.none(), st.floats(-50, 50)), max_size=40), st.integers(1, 8))
def test_streaming_smoother_equals_the_vectorised_filter_bit_for_bit(values, width):
    x = np.array([np.nan if v is None else v for v in values], dtype=np.float64)
    smoother = ContourSmoother(width)
    streamed = np.array([smoother.step(float(v)) for v in x])
    np.testing.assert_array_equal(streamed, smooth_contour(x, width))
