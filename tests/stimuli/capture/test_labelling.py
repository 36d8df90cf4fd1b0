import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.capture.labelling import MarkerTracker, label_neutral
from app.stimuli.capture.markerset import MARKERS
from renderer.headmodel import builtin_face
from renderer.markers import MarkerCamera


@pytest.fixture(scope="module")
def neutral():
    """The 17 markers' pixel positions in the built-in head's neutral pose at 368 px."""
    return MarkerCamera(builtin_face(), 368).pose(np.zeros(68))[0]


def test_neutral_frame_is_labelled_whatever_the_order_of_the_spots(neutral):
    rng = np.random.default_rng(0)
    spots = np.vstack([neutral[rng.permutation(17)], [[20.0, 200.0]]])  # plus a reflection
    np.testing.assert_array_equal(label_neutral(spots), neutral)


def test_a_missing_marker_in_the_first_frame_is_named(neutral):
    with pytest.raises(InputError, match=r"frame 0 \(0.000 s\): marker lip_top not found"):
        label_neutral(np.delete(neutral, MARKERS.index("lip_top"), axis=0))
    with pytest.raises(InputError, match="3 bright spots, fewer than the head frame's 4"):
        label_neutral(neutral[:3])


def moving(neutral, n=30, fps=30.0):
    """The neutral markers drifting right and turning a little: (n, 17, 2) and times."""
    t = np.arange(n) / fps
    angle = np.radians(3) * np.sin(2 * np.pi * t)
    centre = neutral.mean(axis=0)
    rot = np.stack([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    pos = np.einsum("ijt,kj->tki", rot, neutral - centre) + centre + 20 * t[:, None, None]
    return pos, t


def test_spatial_locality_keeps_labels_and_gaps_are_interpolated(neutral):
    pos, t = moving(neutral)
    k = MARKERS.index("brow_inner_l")
    tracker = MarkerTracker(pos[0], t[0])
    for i in range(1, len(t)):
        spots = pos[i][::-1]  # any order
        if 10 <= i <= 14:  # lost for 5 frames (167 ms)
            spots = np.delete(pos[i], k, axis=0)
        tracker.update(spots, t[i])
    tracks = tracker.finish()
    keep = np.r_[0:10, 15:30]
    np.testing.assert_array_equal(tracks.positions[keep], pos[keep])
    # between its last (frame 9) and first (frame 15) sightings: a straight line in time
    w = (t[10:15] - t[9]) / (t[15] - t[9])
    line = pos[9, k] + w[:, None] * (pos[15, k] - pos[9, k])
    np.testing.assert_allclose(tracks.positions[10:15, k], line)
    assert tracks.report == {"lost": {"brow_inner_l": 5}, "gaps": [["brow_inner_l", 10, 14]]}
    assert not tracks.seen[10:15, k].any()


def test_a_marker_lost_too_long_is_named_with_its_frames(neutral):
    pos, t = moving(neutral)
    k = MARKERS.index("nose_bridge")
    tracker = MarkerTracker(pos[0], t[0], max_gap_s=0.2)
    for i in range(1, len(t)):
        tracker.update(np.delete(pos[i], k, axis=0) if i >= 20 else pos[i], t[i])
    with pytest.raises(
        InputError,
        match=r"marker nose_bridge lost from frame 20 \(0.667 s\) "
        r"until the end, longer than the 0.2 s",
    ):
        tracker.finish()


def test_a_marker_reappears_after_the_head_moved(neutral):
    pos, t = moving(neutral, n=12)
    pos[:, :, 0] += 5.0 * np.clip(np.arange(12) - 3, 0, None)[:, None]  # a fast turn
    k = MARKERS.index("lip_corner_l")
    tracker = MarkerTracker(pos[0], t[0])
    for i in range(1, 12):
        tracker.update(np.delete(pos[i], k, axis=0) if 4 <= i <= 7 else pos[i], t[i])
    tracks = tracker.finish()
    np.testing.assert_array_equal(tracks.positions[8:], pos[8:])


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 400), st.floats(0, 400)), max_size=25))
def test_any_first_frame_is_labelled_or_refused_in_one_line(spots):
    try:
        out = label_neutral(np.array(spots, float).reshape(-1, 2))
    except InputError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("frame 0")
    else:
        assert out.shape == (17, 2)
