import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cli import main
from app.errors import InputError
from app.stimuli.capture import sniff
from app.stimuli.capture.bvh import read_bvh
from app.stimuli.capture.headframe import Neutral
from tests.stimuli.capture.files import GENEA_JOINTS, write_bvh

FPS = 30.0
N = 90


def _axis(axis, a):
    c, s = np.cos(a), np.sin(a)
    m = {"x": [[1, 0, 0], [0, c, -s], [0, s, c]], "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]]}
    return np.array(m.get(axis, [[c, -s, 0], [s, c, 0], [0, 0, 1]]))


def head_motion(n=N):
    t = np.arange(n) / FPS
    return t, {
        "pitch": 12 * np.sin(2 * np.pi * 0.5 * t),  # degrees: + down
        "yaw": 20 * np.sin(2 * np.pi * 0.33 * t),  # + to the skeleton's left
        "roll": 6 * np.cos(2 * np.pi * 0.25 * t),
    }


def test_head_angles_in_the_renderers_order_from_one_joint(tmp_path):
    t, m = head_motion()
    joints = tuple(
        (j[0], j[1], j[2], "Yrotation Xrotation Zrotation") if j[0] == "Head" else j
        for j in GENEA_JOINTS
    )
    motion = {
        "Head.Yrotation": m["yaw"],
        "Head.Xrotation": m["pitch"],
        "Head.Zrotation": m["roll"],
        "Spine2.Yrotation": 30 * np.sin(t),  # the torso turns: not the head's motion
        "Hips.Xposition": 10 * t,
    }
    path = write_bvh(tmp_path / "genea.bvh", motion, N, joints=joints)
    assert sniff(path) == "bvh"
    track = read_bvh(path, FPS)
    assert track.channels == (48, 49, 50) and track.n_frames == N
    for fap, name in ((48, "pitch"), (49, "yaw"), (50, "roll")):
        np.testing.assert_allclose(np.degrees(track[fap] * 1e-5), m[name], atol=1e-5)
    report = track.metadata["capture"]
    assert report["joints"] == ["Neck", "Neck1", "Head"] and report["torso"] == "Spine3"
    assert report["facing"] == "LeftShoulder on +x"


def test_neck_and_head_rotations_compose_in_channel_order(tmp_path):
    """GENEA's joints list Zrotation Yrotation Xrotation: R = Rz Ry Rx per joint, and the
    head in the torso is Neck @ Neck1 @ Head."""
    t, m = head_motion()
    motion = {
        "Neck.Xrotation": m["pitch"] / 2,
        "Neck1.Xrotation": m["pitch"] / 2,
        "Neck1.Yrotation": m["yaw"] / 2,
        "Head.Yrotation": m["yaw"] / 2,
        "Head.Zrotation": m["roll"],
    }
    track = read_bvh(write_bvh(tmp_path / "g.bvh", motion, N), FPS)
    for k in (0, 17, 55, 89):
        d = {key: np.radians(round(float(v[k]), 6)) for key, v in motion.items()}
        neck = _axis("x", d["Neck.Xrotation"])
        neck1 = _axis("y", d["Neck1.Yrotation"]) @ _axis("x", d["Neck1.Xrotation"])
        head = _axis("z", d["Head.Zrotation"]) @ _axis("y", d["Head.Yrotation"])
        pitch, yaw, roll = (track[f][k] * 1e-5 for f in (48, 49, 50))
        rebuilt = _axis("y", yaw) @ _axis("x", pitch) @ _axis("z", roll)
        np.testing.assert_allclose(rebuilt, neck @ neck1 @ head, atol=1e-9)


def test_a_skeleton_facing_minus_z_reads_the_same_head_motion(tmp_path):
    t, m = head_motion()
    motion = {"Head.Xrotation": m["pitch"], "Head.Yrotation": m["yaw"]}
    plus = read_bvh(write_bvh(tmp_path / "a.bvh", motion, N), FPS)
    # facing -Z: a nod down is a negative rotation about X, a turn to its left still +Y
    mirrored = {"Head.Xrotation": -m["pitch"], "Head.Yrotation": m["yaw"]}
    minus = read_bvh(write_bvh(tmp_path / "b.bvh", mirrored, N, mirror_x=True), FPS)
    assert minus.metadata["capture"]["facing"] == "LeftShoulder on -x"
    for fap in (48, 49):
        np.testing.assert_allclose(minus[fap], plus[fap], atol=1e-3)


def test_neutral_options_and_the_cli(tmp_path):
    t, m = head_motion()
    path = write_bvh(tmp_path / "g.bvh", {"Head.Xrotation": 15 + m["pitch"]}, N)
    rest = read_bvh(path, FPS)
    np.testing.assert_allclose(np.degrees(rest[48] * 1e-5), 15 + m["pitch"], atol=1e-5)
    median = read_bvh(path, FPS, neutral=Neutral("median"))
    assert abs(np.degrees(np.median(median[48]) * 1e-5)) < 1e-6
    r = CliRunner().invoke(
        main, ["capture", "import", str(path), "--out", str(tmp_path / "g.fap"), "--fps", "25"]
    )
    assert r.exit_code == 0, r.output
    assert "75 frames at 25 fps from 90 samples at 30 fps; FAPs 48, 49, 50" in r.output
    assert "head relative to the skeleton's rest pose" in r.output
    assert "head from joints Neck, Neck1, Head (LeftShoulder on +x)" in r.output


def test_a_skeleton_that_is_not_y_up_is_refused(tmp_path):
    joints = tuple((j[0], j[1], (j[2][0], j[2][2], j[2][1]), j[3]) for j in GENEA_JOINTS)
    path = write_bvh(tmp_path / "zup.bvh", {}, 3, joints=joints)
    with pytest.raises(InputError, match=r"zup.bvh: the neck runs along .* not up \+Y"):
        read_bvh(path)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            lambda s: s.replace("Frames: 5", "Frames: 6"),
            r":\d+: Frames says 6, the file has 5 frame lines \(truncated\)",
        ),
        (
            lambda s: s.replace(
                "CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 3 Zrotation Yrotation", 1
            ),
            r":9: CHANNELS: expected distinct X/Y/Z position/rotation, got Zrotation Yrotation J",
        ),
        (
            lambda s: s.replace("OFFSET 0.000000 8.000000", "OFFSET 0.000000 eight", 1),
            r"OFFSET: 'eight' is not a number",
        ),
        (
            lambda s: s.rsplit("\n", 2)[0] + "\n" + " ".join(["1"] * 40) + "\n",
            r":\d+: 40 values for 39 channels",
        ),
        (lambda s: s.replace("HIERARCHY", "HIERARCH"), r":1: expected HIERARCHY"),
        (lambda s: s.replace("JOINT Head", "JOINT Face"), r"no head joint"),
    ],
)
def test_malformed_files_name_the_line(tmp_path, edit, message):
    text = write_bvh(tmp_path / "g.bvh", {}, 5).read_text()
    path = tmp_path / "bad.bvh"
    path.write_text(edit(text))
    with pytest.raises(
        InputError, match="bad.bvh" + message if message.startswith(":") else message
    ):
        read_bvh(path)


_WORDS = [
    "HIERARCHY",
    "ROOT",
    "JOINT",
    "End",
    "Site",
    "OFFSET",
    "CHANNELS",
    "{",
    "}",
    "MOTION",
    "Frames:",
    "Frame",
    "Time:",
    "Head",
    "Neck",
    "Xrotation",
    "Yposition",
    "3",
    "0",
    "1.5",
    "-2",
    "nan",
    "1e999",
    "\n",
]


@settings(
    max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(st.sampled_from(_WORDS), max_size=60))
def test_any_bvh_like_text_is_a_track_or_one_input_error(tmp_path, words):
    path = tmp_path / "any.bvh"
    path.write_text(" ".join(words))
    try:
        read_bvh(path)
    except InputError as exc:
        assert "\n" not in str(exc) and "any.bvh" in str(exc)


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.data())
def test_damaged_real_files_are_a_track_or_one_input_error(tmp_path, data):
    text = write_bvh(tmp_path / "g.bvh", {"Head.Xrotation": np.arange(4.0)}, 4).read_text()
    tokens = text.split(" ")
    for _ in range(data.draw(st.integers(1, 4))):
        k = data.draw(st.integers(0, len(tokens) - 1))
        tokens[k] = data.draw(st.sampled_from(_WORDS + ["", "x", "99999999999999999999"]))
    path = tmp_path / "damaged.bvh"
    path.write_text(" ".join(tokens))
    try:
        read_bvh(path)
    except InputError as exc:
        assert "\n" not in str(exc) and "damaged.bvh" in str(exc)


@settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.binary(max_size=200))
def test_any_bytes_are_one_input_error(tmp_path, data):
    path = tmp_path / "b.bvh"
    path.write_bytes(b"HIERARCHY\n" + data)
    try:
        read_bvh(path)
    except InputError as exc:
        assert "\n" not in str(exc) and "b.bvh" in str(exc)
