import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.conditions import CONDITIONS, DISPLAY_NAMES, make_condition
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


def test_registry_names():
    assert (
        set(CONDITIONS)
        == set(DISPLAY_NAMES)
        == {"none", "random", "speech_driven", "ground_truth", "live_gmm"}
    )
    assert CONDITIONS["live_gmm"] == "app.stimuli.live.condition:LiveGmmCondition"


def test_unknown_condition_and_parameter():
    with pytest.raises(InputError, match="unknown condition 'nope'"):
        make_condition("nope")
    with pytest.raises(InputError, match="condition 'none'"):
        make_condition("none", bogus=1)


def test_missing_module_is_one_clear_line(monkeypatch):
    import app.stimuli.conditions as reg

    monkeypatch.setitem(reg.CONDITIONS, "live_gmm", "app.stimuli.nowhere.condition:X")
    with pytest.raises(InputError, match="not available in this installation") as err:
        make_condition("live_gmm")
    assert "\n" not in str(err.value)


def test_none_zeroes_prosody_and_carries_lips():
    n = 30
    feats = SpeechFeatures(30.0, np.full(n, 120.0), np.full(n, 60.0), np.full(n, 120.0))
    gt = MotionTrack.from_channels(
        30.0, {3: np.arange(n) * 1.0, 48: np.ones(n) * 500, 19: np.ones(n) * 7, 31: np.ones(n) * 9}
    )
    track = make_condition("none").generate(feats, ground_truth=gt)
    assert track.name == "NO_PROSODY"
    np.testing.assert_array_equal(track[3], gt[3])
    assert 19 not in track  # the eyes are the study's setting (app.stimuli.eyes), not carried
    assert np.all(track[48] == 0) and np.all(track[31] == 0) and 50 in track
    with pytest.raises(InputError, match="takes no arguments"):
        make_condition("none", eyes="closed")  # eyes are a study setting, not a condition's


def test_ground_truth_is_aligned_and_resampled():
    fps_capture, n = 120.0, 480  # 4 s capture at 120 Hz
    t = np.arange(n) / fps_capture
    gt = MotionTrack.from_channels(
        fps_capture, {48: 1000 * np.sin(2 * np.pi * 0.5 * t)}, source="capture"
    )
    feats = SpeechFeatures(30.0, np.zeros(90), np.zeros(90), np.zeros(90))  # 3 s of audio
    track = make_condition("ground_truth").generate(feats, ground_truth=gt)
    assert track.fps == 30 and track.n_frames == 90 and track.name == "GROUND_TRUTH"
    expected = 1000 * np.sin(2 * np.pi * 0.5 * np.arange(90) / 30)
    np.testing.assert_allclose(track[48][10:80], expected[10:80], atol=5)
    shifted = make_condition("ground_truth", offset=1.0).generate(feats, ground_truth=gt)
    np.testing.assert_allclose(shifted[48][40:80], expected[10:50], atol=5)
    with pytest.raises(InputError, match="needs a ground-truth track"):
        make_condition("ground_truth").generate(feats)
