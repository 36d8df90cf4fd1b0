import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack, align_to_features


def sine_track(fps, seconds, freq=0.5, channels=(48, 49)):
    t = np.arange(round(fps * seconds)) / fps
    cols = {c: 1000 * np.sin(2 * np.pi * freq * t + k) for k, c in enumerate(channels)}
    return MotionTrack.from_channels(fps, cols, name="sine")


def test_validation():
    with pytest.raises(ValueError):
        MotionTrack(0, np.zeros((3, 1)), (48,))
    with pytest.raises(ValueError):
        MotionTrack(30, np.zeros((3, 2)), (48,))
    with pytest.raises(ValueError):
        MotionTrack(30, np.zeros((3, 2)), (49, 48))
    with pytest.raises(ValueError):
        MotionTrack(30, np.zeros((3, 1)), (69,))


def test_access_and_neutral_absent_channels():
    t = sine_track(30, 1)
    assert t.n_frames == 30 and t.duration == 1.0
    assert 48 in t and 50 not in t
    assert np.all(t.get(50) == 0)
    with pytest.raises(KeyError):
        t[50]
    dense = t.dense()
    assert dense.shape == (30, 68)
    np.testing.assert_array_equal(dense[:, 47], t[48])
    assert np.all(dense[:, 49] == 0)


def test_with_select_drop():
    t = sine_track(30, 1)
    u = t.with_channels({31: np.ones(30)})
    assert u.channels == (31, 48, 49) and t.channels == (48, 49)
    assert u.select([31, 50]).channels == (31,)
    assert u.drop([48]).channels == (31, 49)
    with pytest.raises(ValueError):
        t.with_channels({31: np.ones(29)})


@pytest.mark.parametrize("src,dst", [(120, 30), (30, 25), (25, 24), (24, 30), (30, 60)])
def test_resample_keeps_a_slow_signal(src, dst):
    t = sine_track(src, 4)
    r = t.resample(dst)
    assert r.fps == dst and r.n_frames == round(4 * dst)
    expected = 1000 * np.sin(2 * np.pi * 0.5 * r.times)
    inner = slice(dst // 2, -dst // 2)  # filter edge effects aside
    np.testing.assert_allclose(r[48][inner], expected[inner], atol=5)


def test_resample_downsampling_removes_aliasing():
    fps = 120
    t = np.arange(fps * 4) / fps
    jitter = 100 * np.sin(2 * np.pi * 29 * t)  # would alias to 1 Hz at 30 fps
    track = MotionTrack.from_channels(fps, {48: jitter})
    assert np.abs(track.resample(30)[48][15:-15]).max() < 10


def test_fit_length():
    t = sine_track(30, 1)
    assert t.fit_length(10).n_frames == 10
    longer = t.fit_length(40)
    assert longer.n_frames == 40 and np.all(longer[48][30:] == t[48][-1])


def frames_of_audio(n, fps=30.0):
    return SpeechFeatures(fps, np.zeros(n), np.zeros(n), np.zeros(n))


def test_align_to_features_resamples_cuts_and_shifts_a_capture():
    capture = sine_track(120.0, 4.0)  # 4 s at 120 Hz against 3 s of audio at 30 fps
    aligned = align_to_features(capture, frames_of_audio(90))
    assert aligned.fps == 30.0 and aligned.n_frames == 90
    late = align_to_features(capture, frames_of_audio(90), offset=0.5)  # started 0.5 s later
    np.testing.assert_array_equal(late.values[:15], np.repeat(aligned.values[:1], 15, axis=0))
    np.testing.assert_allclose(late.values[15:], aligned.values[:75])
    early = align_to_features(capture, frames_of_audio(90), offset=-0.5)
    np.testing.assert_allclose(early.values[:75], aligned.values[15:])
    assert not np.allclose(early.values[75:], early.values[74])  # the capture goes on


@given(st.integers(1, 200), st.sampled_from([24.0, 25.0, 30.0, 60.0]))
def test_aligning_an_aligned_track_changes_nothing(n, fps):
    track = align_to_features(sine_track(120.0, 2.0), frames_of_audio(n, fps))
    again = align_to_features(track, frames_of_audio(n, fps))
    assert again.equals(track) and again.n_frames == n
