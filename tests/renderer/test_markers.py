import numpy as np
import pytest

from app.stimuli.capture.markerset import MARKERS, NEUTRAL_LAYOUT
from app.stimuli.track import MotionTrack
from renderer.headmodel import builtin_face
from renderer.markers import (
    MarkerCamera,
    MarkerLook,
    calibration_motion,
    frame_points,
    known_motion,
    marker_frames,
)


@pytest.fixture(scope="module")
def camera():
    return MarkerCamera(builtin_face(), 368)


def faps(**values):
    out = np.zeros(68)
    for key, v in values.items():
        out[int(key[1:]) - 1] = v
    return out


def test_the_neutral_layout_is_the_built_in_heads(camera):
    px = camera.pose(np.zeros(68))[0]
    tl, tr, bl, br = px[:4]
    for name, (u, v) in NEUTRAL_LAYOUT.items():
        p = px[MARKERS.index(name)]
        got_u = (p[0] - (tl[0] + bl[0]) / 2) / ((tr[0] + br[0] - tl[0] - bl[0]) / 2)
        got_v = (p[1] - (tl[1] + tr[1]) / 2) / ((bl[1] + br[1] - tl[1] - tr[1]) / 2)
        assert (got_u, got_v) == pytest.approx((u, v), abs=0.002), name


def test_markers_follow_the_deformation_and_the_frame_follows_the_head(camera):
    neutral = camera.pose(np.zeros(68))[0]
    raised = camera.pose(faps(f31=300.0))[0]
    moved = np.flatnonzero(np.abs(raised - neutral).max(axis=1) > 1e-6)
    assert [MARKERS[k] for k in moved] == ["brow_inner_l"]
    assert raised[moved[0], 1] < neutral[moved[0], 1]  # up in the image
    # pitch down: the frame's top nears the camera (longer), its bottom recedes
    pitched = camera.pose(faps(f48=np.radians(15) / 1e-5))[0]
    width = lambda p, a, b: np.linalg.norm(p[MARKERS.index(a)] - p[MARKERS.index(b)])  # noqa: E731
    assert width(pitched, "TL", "TR") / width(pitched, "BL", "BR") > 1.03
    face = builtin_face()
    posts = frame_points(face)
    assert np.all(posts[:, 0] * [1, -1, 1, -1] < 0)  # TL, BL on the face's right (-x)


def test_a_marker_turned_away_is_hidden(camera):
    visible = camera.pose(faps(f49=np.radians(85) / 1e-5))[1]  # turned to the face's left
    assert not visible[MARKERS.index("cheek_l")] and visible[MARKERS.index("cheek_r")]
    assert camera.pose(np.zeros(68))[1].all()


def test_look_noise_is_seeded_and_markers_are_bright_on_a_dark_face():
    track = MotionTrack.zeros(30.0, 1, (48,))
    clean = next(marker_frames(track, 128))
    a, b = (next(marker_frames(track, 128, look=MarkerLook(noise=5.0, seed=s))) for s in (1, 1))
    assert np.array_equal(a, b) and not np.array_equal(a, clean)
    face_level = np.median(clean[clean > 0])
    assert 20 < face_level < 80 and (clean > 128).sum() >= 17 * 4  # 3 px markers


def test_known_motions_stay_in_the_thesis_ranges():
    cal, known = calibration_motion(), known_motion()
    assert np.degrees(np.abs(cal[48]).max() * 1e-5) == pytest.approx(17.0, abs=0.1)
    assert np.degrees(np.abs(cal[49]).max() * 1e-5) == pytest.approx(8.0, abs=0.1)
    for fap, limit in ((48, 17), (49, 8), (50, 10)):
        assert np.degrees(np.abs(known[fap]).max() * 1e-5) <= limit
    assert np.all(known.dense()[:15] == 0)  # a neutral first half second
