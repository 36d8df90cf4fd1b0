"""The rig moves each FAP group in its MPEG-4 direction (no GL needed)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from renderer.deform import SUPPORTED_FAPS, Rig
from renderer.headmodel import builtin_face


@pytest.fixture(scope="module")
def rig():
    return Rig(builtin_face())


def _faps(**values):
    f = np.zeros(68)
    for k, v in values.items():
        f[int(k[1:]) - 1] = v
    return f


def _moved(rig, faps, fp):
    frame = rig.deform(faps)
    i = rig.face.fp_vertices[fp]
    return frame.positions[i].astype(float) - rig.face.vertices[i].astype(float)


def test_neutral_faps_leave_the_mesh_unchanged(rig):
    frame = rig.deform(np.zeros(68))
    assert np.array_equal(frame.positions, rig.face.vertices)
    assert np.allclose(frame.head, np.eye(4)) and np.allclose(frame.eye_l, np.eye(4))


@pytest.mark.parametrize(
    "fap, fp, axis, sign",
    [
        (31, "4.1", 1, 1),
        (32, "4.2", 1, 1),
        (33, "4.3", 1, 1),
        (34, "4.4", 1, 1),
        (35, "4.5", 1, 1),
        (36, "4.6", 1, 1),
        (37, "4.1", 0, -1),
        (38, "4.2", 0, 1),
        (4, "2.2", 1, -1),
        (5, "2.3", 1, 1),
        (6, "2.4", 0, 1),
        (7, "2.5", 0, -1),
        (8, "2.6", 1, -1),
        (9, "2.7", 1, -1),
        (10, "2.8", 1, 1),
        (11, "2.9", 1, 1),
        (12, "2.4", 1, 1),
        (13, "2.5", 1, 1),
        (16, "2.3", 2, 1),
        (17, "2.2", 2, 1),
        (18, "2.10", 1, 1),
        (51, "8.1", 1, -1),
        (52, "8.2", 1, 1),
        (53, "8.3", 0, 1),
        (54, "8.4", 0, -1),
        (55, "8.5", 1, -1),
        (56, "8.6", 1, -1),
        (57, "8.7", 1, 1),
        (58, "8.8", 1, 1),
        (59, "8.3", 1, 1),
        (60, "8.4", 1, 1),
        (3, "2.1", 1, -1),
        (14, "2.1", 2, 1),
        (15, "2.1", 0, -1),
        (19, "3.1", 1, -1),
        (20, "3.2", 1, -1),
        (21, "3.3", 1, 1),
        (22, "3.4", 1, 1),
    ],
)
def test_translational_faps_move_their_point_the_mpeg4_way(rig, fap, fp, axis, sign):
    d = _moved(rig, _faps(**{f"f{fap}": 200.0}), fp)
    assert sign * d[axis] > 0.5, d


def test_feature_point_moves_by_value_times_fapu(rig):
    # 2.2 sits at the centre of its own zone: weight 1, FAPU MNS = MNS0 / 1024
    d = _moved(rig, _faps(f4=512.0), "2.2")
    assert d[1] == pytest.approx(-512 * rig.face.fapu["MNS0"] / 1024, rel=0.02)


def test_open_jaw_lowers_the_chin_by_value_times_mns(rig):
    d = _moved(rig, _faps(f3=100.0), "2.1")
    assert -d[1] == pytest.approx(100 * rig.face.fapu["MNS0"] / 1024, rel=0.1)


def test_jaw_parts_the_lips(rig):
    up = _moved(rig, _faps(f3=400.0), "2.2")
    low = _moved(rig, _faps(f3=400.0), "2.3")
    assert abs(up[1]) < 0.05 and low[1] < -3.0


def test_full_eyelid_closure_brings_the_upper_lid_to_the_lower(rig):
    fp = rig.face.feature_points
    frame = rig.deform(_faps(f19=1024.0))
    top = frame.positions[rig.face.fp_vertices["3.1"]]
    assert top[1] == pytest.approx(fp["3.3"][1], abs=1.5)


def test_head_rotations_follow_mpeg4(rig):
    nose = rig.face.feature_points["9.15"]

    def moved(**v):
        m = rig.deform(_faps(**v)).head
        return m[:3, :3] @ nose + m[:3, 3] - nose

    assert moved(f49=10000)[0] > 1.0  # yaw: towards the face's own left (+x)
    assert moved(f48=10000)[1] < -1.0  # pitch: down
    top = np.array([0.0, 120.0, 0.0])
    m = rig.deform(_faps(f50=10000)).head
    assert (m[:3, :3] @ top + m[:3, 3])[0] < top[0] - 1.0  # roll: top to the face's right


def test_gaze_rotates_eyeballs_the_mpeg4_way(rig):
    pupil = rig.face.feature_points["3.5"]
    m = rig.deform(_faps(f23=20000)).eye_l
    assert (m[:3, :3] @ pupil + m[:3, 3])[0] > pupil[0] + 1.0  # yaw: left
    m = rig.deform(_faps(f25=20000)).eye_l
    assert (m[:3, :3] @ pupil + m[:3, 3])[1] < pupil[1] - 1.0  # pitch: down
    assert np.allclose(rig.deform(_faps(f23=20000)).eye_r, np.eye(4))


def test_every_supported_fap_moves_the_face(rig):
    neutral = rig.deform(np.zeros(68))
    for fap in SUPPORTED_FAPS:
        fr = rig.deform(_faps(**{f"f{fap}": 300.0 if fap < 48 or fap > 50 else 20000.0}))
        moved = (
            np.abs(fr.positions - neutral.positions).max() > 0.5
            or not np.allclose(fr.head, neutral.head)
            or not np.allclose(fr.eye_l, neutral.eye_l)
            or not np.allclose(fr.eye_r, neutral.eye_r)
        )
        assert moved, fap


def test_equal_brow_values_raise_the_brow_uniformly(rig):
    d = [_moved(rig, _faps(f31=100, f33=100, f35=100), p)[1] for p in ("4.1", "4.3", "4.5")]
    assert np.allclose(d, d[0], rtol=0.05)


def test_posed_turns_the_head_about_7_1_and_the_eyes_about_their_centres():
    from renderer.deform import rotation

    rig = Rig(builtin_face())
    faps = np.zeros(68)
    faps[49 - 1] = 20000.0  # head yaw 0.2 rad
    faps[23 - 1] = 10000.0  # left eyeball yaw 0.1 rad
    frame = rig.deform(faps)
    before = frame.positions.copy(), frame.normals.copy()
    pos, nrm = rig.posed(frame)
    # the frame itself is left as it was (it may be posed again)
    assert np.array_equal(frame.positions, before[0]) and np.array_equal(frame.normals, before[1])
    w = rig.weights["head"]
    head, shoulders = int(np.argmax(w)), int(np.argmin(w))
    assert w[head] == 1.0 and w[shoulders] == 0.0
    pivot = rig.pivot
    expected = rotation("y", 0.2) @ (rig.v0[head] - pivot) + pivot
    np.testing.assert_allclose(pos[head], expected, atol=1e-3)
    np.testing.assert_allclose(pos[shoulders], rig.v0[shoulders], atol=1e-6)
    eye = rig.eye_vertices["l"][0]
    centre = rig.eye_centres["l"]
    on_eye = rotation("y", 0.1) @ (rig.v0[eye] - centre) + centre
    np.testing.assert_allclose(pos[eye], rotation("y", 0.2) @ (on_eye - pivot) + pivot, atol=1e-3)
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1.0, atol=1e-5)
    # down the neck each vertex turns by its head weight's share of the angle: it bends
    neck = int(np.argmin(np.abs(w - 0.5)))
    assert 0.2 < w[neck] < 0.8
    turned = rotation("y", 0.2 * w[neck]) @ (rig.v0[neck] - pivot) + pivot
    np.testing.assert_allclose(pos[neck], turned, atol=1e-3)
    np.testing.assert_allclose(nrm[neck], rotation("y", 0.2 * w[neck]) @ rig.n0[neck], atol=1e-5)


def test_a_rolled_head_bends_its_neck():
    # rolled 20 degrees, the neck's rings turn more the higher they are: the neck leans with
    # the head (a blend of positions kept every ring upright, a broken neck under the head)
    from renderer.deform import rotation

    rig = Rig(builtin_face())
    faps = np.zeros(68)
    faps[50 - 1] = np.radians(20.0) / 1e-5
    pos, _ = rig.posed(rig.deform(faps))
    w = rig.weights["head"]
    blend = np.flatnonzero((w > 0.05) & (w < 0.95))
    # each ring's axis: the line through the centres of its vertices at one weight
    heights = np.unique(np.round(w[blend], 3))
    tilt = []
    for h in heights[:: max(1, len(heights) // 6)]:
        ring = blend[np.round(w[blend], 3) == h]
        if len(ring) < 8:
            continue
        a, b = pos[ring], rig.v0[ring]
        # the ring's plane normal: least-squares plane through the posed ring
        n_posed = np.linalg.svd(a - a.mean(axis=0))[2][-1]
        n_rest = np.linalg.svd(b - b.mean(axis=0))[2][-1]
        angle = np.degrees(np.arccos(min(1.0, abs(float(n_posed @ n_rest)))))
        # a ring turned by its share of the roll about z tilts its plane by this much
        share = rotation("z", np.radians(20.0 * h)) @ n_rest
        expected = np.degrees(np.arccos(min(1.0, abs(float(share @ n_rest)))))
        tilt.append(angle)
        assert angle == pytest.approx(expected, abs=0.5)
    assert len(tilt) >= 3 and tilt == sorted(tilt) and tilt[-1] > 8.0


_MOVING = (
    3,
    4,
    5,
    8,
    12,
    14,
    15,
    16,
    17,
    18,
    19,
    21,
    23,
    26,
    31,
    34,
    35,
    37,
    48,
    49,
    50,
    51,
    55,
    59,
)


@settings(max_examples=30, deadline=None)
@given(values=st.lists(st.floats(-600, 600), min_size=len(_MOVING), max_size=len(_MOVING)))
def test_the_mouth_at_rest_is_the_frame_with_the_jaw_and_lip_faps_at_zero(rig, values):
    from renderer.deform import MOUTH_FAPS

    faps = np.zeros(68)
    for fap, v in zip(_MOVING, values, strict=True):
        faps[fap - 1] = v * (50.0 if fap >= 48 else 1.0)  # head turns up to 0.3 rad
    rest = rig.mouth_at_rest(rig.deform(faps), faps)
    zeroed = faps.copy()
    zeroed[np.array(MOUTH_FAPS) - 1] = 0.0
    expected = rig.deform(zeroed)
    for got, want in (
        (rest.positions, expected.positions),
        (rest.normals, expected.normals),
        (rest.head, expected.head),
        (rest.eye_l, expected.eye_l),
    ):
        np.testing.assert_array_equal(got, want)


def test_the_built_in_mouth_comes_to_rest_without_a_second_deformation(rig, monkeypatch):
    faps = _faps(f3=400, f5=-200, f31=300, f49=20000)
    frame = rig.deform(faps)
    monkeypatch.setattr(rig, "deform", lambda f: pytest.fail("deformed again"))
    rest = rig.mouth_at_rest(frame, faps)
    chin = rig.face.fp_vertices["2.1"]
    np.testing.assert_array_equal(rest.positions[chin], rig.v0[chin])
    brow = rig.face.fp_vertices["4.1"]
    np.testing.assert_array_equal(rest.positions[brow], frame.positions[brow])  # still raised


def test_a_face_whose_brows_reach_the_mouth_deforms_again_for_the_mouth_at_rest():
    import dataclasses

    face = builtin_face()
    # squash the face vertically so that the brows' zone reaches the lips
    squashed = face.vertices.copy()
    squashed[:, 1] *= 0.2
    fp = {k: v * np.array([1.0, 0.2, 1.0]) for k, v in face.feature_points.items()}
    tight = Rig(dataclasses.replace(face, vertices=squashed, feature_points=fp))
    assert tight.rest_mouth_vertices is None
    faps = _faps(f3=300, f31=200)
    rest = tight.mouth_at_rest(tight.deform(faps), faps)
    np.testing.assert_array_equal(rest.positions, tight.deform(_faps(f31=200)).positions)


def test_rotations_turn_the_way_the_fap_table_says():
    """Positive head pitch moves the front down, yaw to the face's left (+x), roll the top to
    the face's right; positive eyeball yaw and pitch likewise (reference mpeg4-fap)."""
    from app.stimuli import fap
    from renderer.deform import EYE_TURNS, HEAD_TURNS, fap_rotation

    front, top = np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    expected = {"down": (front, 1, -1), "left": (front, 0, 1), "right": (top, 0, -1)}
    for turns in (HEAD_TURNS, *EYE_TURNS.values()):
        for f in turns:
            faps = np.zeros(68)
            faps[f - 1] = 10000.0
            point, axis, sign = expected[fap.FAPS[f].positive]
            moved = fap_rotation(faps, turns) @ point
            assert np.sign(moved[axis]) == sign, (f, moved)
    assert EYE_TURNS == {"l": (23, 25), "r": (24, 26)} and HEAD_TURNS == (49, 48, 50)
