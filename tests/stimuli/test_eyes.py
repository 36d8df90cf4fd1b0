import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.eyes import EYE_CHANNELS, check_eyes, eye_channels
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


def feats(n=90):
    t = np.arange(n) / 30.0
    f0 = np.where((t % 2) < 1.5, 120 + 20 * np.sin(2 * np.pi * t), 0.0)
    return SpeechFeatures(30.0, f0, np.where(f0 > 0, 70.0, 40.0), np.full(n, 120.0))


def test_still_eyes_are_neutral():
    cols = eye_channels("still", feats())
    assert sorted(cols) == list(EYE_CHANNELS) and all(np.all(v == 0) for v in cols.values())


def test_ground_truth_eyes_are_copied_as_captured():
    n = 90
    gt = MotionTrack.from_channels(30.0, {19: np.arange(n) * 1.0, 23: np.full(n, 500.0)})
    cols = eye_channels("ground_truth", feats(n), gt)
    np.testing.assert_array_equal(cols[19], gt[19])
    np.testing.assert_array_equal(cols[23], gt[23])
    assert sorted(cols) == [19, 23]  # the capture's own eye channels, no invented ones
    with pytest.raises(InputError, match="needs a ground-truth track"):
        eye_channels("ground_truth", feats(n))


def test_generated_eyes_come_from_the_live_model_and_follow_the_seed():
    a, b = (eye_channels("generated", feats(300), seed=s) for s in (1, 1))
    c = eye_channels("generated", feats(300), seed=2)
    np.testing.assert_array_equal(a[23], b[23])
    assert np.ptp(a[23]) > 0 or np.ptp(a[19]) > 0
    assert any(not np.array_equal(a[k], c[k]) for k in EYE_CHANNELS)


def test_unknown_mode_names_the_field():
    with pytest.raises(InputError, match="eyes must be one of still, ground_truth, generated"):
        check_eyes("closed")
