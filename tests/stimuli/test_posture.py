import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.posture import check_posture, rest_posture, share_posture
from app.stimuli.track import MotionTrack


def test_rest_is_the_ground_truths_median_pose_or_neutral():
    gt = MotionTrack.from_channels(
        30.0, {48: np.array([0.0, 10, 10, 10, 500]), 49: np.array([-7.0, -7, 3, -7, 90])}
    )
    assert rest_posture(gt) == {48: 10.0, 49: -7.0, 50: 0.0}  # 50 absent: neutral
    assert rest_posture(None) == {48: 0.0, 49: 0.0, 50: 0.0}


def test_each_track_is_shifted_to_the_rest_and_keeps_its_motion():
    moving = MotionTrack.from_channels(30.0, {48: np.array([1.0, 2, 3, 4, 100]), 31: np.ones(5)})
    still = MotionTrack.zeros(30.0, 5, (31,))  # no head channel at all
    rest = {48: 50.0, 49: -20.0, 50: 5.0}
    out = share_posture({"a": moving, "b": still}, rest)
    assert out["a"][48].tolist() == [48.0, 49.0, 50.0, 51.0, 147.0]  # median 3 -> 50
    np.testing.assert_array_equal(out["a"][31], moving[31])
    for c, v in rest.items():
        np.testing.assert_array_equal(out["b"][c], np.full(5, v))
    assert check_posture("per_condition") == "per_condition"
    with pytest.raises(InputError, match="posture must be one of shared, per_condition"):
        check_posture("front")
