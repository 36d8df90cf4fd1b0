import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cli import main
from app.errors import InputError
from app.stimuli.capture import sniff_csv
from app.stimuli.capture.headframe import Neutral
from app.stimuli.capture.openface import read_openface
from app.stimuli.io import load_track
from tests.stimuli.capture.files import openface_header, write_openface

FPS = 30.0


def known_motion(n=300, drop=()):
    """Known head, gaze, brow and blink signals at 30 fps; ``drop`` frames are missing."""
    t = np.arange(n) / FPS
    keep = np.setdiff1d(np.arange(n), drop)
    values = {
        "pose_Rx": 0.10 * np.sin(2 * np.pi * 0.5 * t),  # nod: +/- 5.7 deg
        "pose_Ry": 0.20 * np.sin(2 * np.pi * 0.25 * t),  # turn
        "pose_Rz": 0.05 * np.cos(2 * np.pi * 0.3 * t),
        "gaze_angle_x": 0.15 * np.sin(2 * np.pi * 0.4 * t),
        "gaze_angle_y": -0.05 * np.ones(n),
        "AU01_r": 2.0 * (np.sin(2 * np.pi * 0.2 * t) > 0),
        "AU02_r": np.full(n, 1.0),
        "AU04_r": np.zeros(n),
        "AU45_r": np.where((t % 3) < 0.2, 4.0, 0.0),
        "AU26_r": np.full(n, 0.5),
    }
    return t, keep, values


def test_known_signals_map_to_faps_with_their_signs_and_units(tmp_path):
    t, keep, v = known_motion()
    path = write_openface(tmp_path / "of.csv", t, v)
    assert sniff_csv(path) == "openface"
    track = read_openface(path, FPS)
    assert track.n_frames == 300 and track.fps == FPS
    # radians -> AU (1e-5 rad), relative to the median pose; small angles: the old linear table
    # (the Euler orders of OpenFace, Rx Ry Rz, and of the renderer, Ry Rx Rz, differ at second
    # order, up to 0.1 x 0.2 rad here)
    for fap, name, sign in ((48, "pose_Rx", 1), (49, "pose_Ry", -1), (50, "pose_Rz", -1)):
        angle = np.round(v[name], 3)
        expected = sign * (angle - np.median(angle)) / 1e-5
        np.testing.assert_allclose(track[fap], expected, atol=2500, err_msg=str(fap))
    np.testing.assert_allclose(track[23], track[24])  # one mean direction for both eyes
    assert np.corrcoef(track[23], v["gaze_angle_x"] + v["pose_Ry"])[0, 1] > 0.99
    assert track[25].mean() < 0  # looking up: negative pitch (down +)
    np.testing.assert_allclose(track[31], 25 * v["AU01_r"])
    np.testing.assert_allclose(track[33], 25 * (v["AU01_r"] + 1.0) / 2)
    np.testing.assert_allclose(track[35], 25.0)
    assert track[19].max() == pytest.approx(0.8 * 1024) and track[21].max() == pytest.approx(
        0.2 * 1024
    )
    assert track[3].mean() == pytest.approx(60.0)
    assert track.metadata["capture"]["missing"] == {}


def _axis(axis, a):
    c, s = np.cos(a), np.sin(a)
    m = {"x": [[1, 0, 0], [0, c, -s], [0, s, c]], "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]]}
    return np.array(m.get(axis, [[c, -s, 0], [s, c, 0], [0, 0, 1]]))


def test_head_angles_are_openfaces_rotation_in_the_renderers_order(tmp_path):
    """FAP 48-50 rebuild OpenFace's R = Rx Ry Rz (camera frame) as Ry(yaw) Rx(pitch) Rz(roll)
    in the face frame (x left, y up, z out of the face): F R F with F = diag(1, -1, -1)."""
    t, _, v = known_motion()
    path = write_openface(tmp_path / "of.csv", t, v)
    track = read_openface(path, FPS, neutral=Neutral("none"))
    f = np.diag([1.0, -1.0, -1.0])
    for k in (0, 37, 120, 299):
        rx, ry, rz = (round(float(v[c][k]), 3) for c in ("pose_Rx", "pose_Ry", "pose_Rz"))
        camera = _axis("x", rx) @ _axis("y", ry) @ _axis("z", rz)
        pitch, yaw, roll = (track[c][k] * 1e-5 for c in (48, 49, 50))
        rebuilt = _axis("y", yaw) @ _axis("x", pitch) @ _axis("z", roll)
        np.testing.assert_allclose(rebuilt, f @ camera @ f, atol=1e-9)
    assert track.metadata["capture"]["neutral"]["method"] == "none"


def test_head_is_relative_to_the_takes_neutral_pose(tmp_path):
    """A camera below the face reads 17 degrees of pitch in every frame: by default the head
    is measured from the take's median pose; a calibration window picks its own neutral."""
    t = np.arange(300) / FPS
    nod = 0.1 * np.sin(2 * np.pi * 0.5 * t)
    offset = 0.3 + np.where(t < 1.0, -0.2, 0.0)  # the first second: looking down at notes
    path = write_openface(tmp_path / "of.csv", t, {"pose_Rx": offset + nod})
    track = read_openface(path, FPS)
    truth = np.round(offset + nod, 3)
    np.testing.assert_allclose(track[48], (truth - np.median(truth)) / 1e-5, atol=1e-6)
    neutral = track.metadata["capture"]["neutral"]
    assert neutral["pitch_deg"] == pytest.approx(np.degrees(np.median(truth)), abs=0.01)
    assert abs(track[48][t >= 1].mean()) < 0.03 / 1e-5  # not the camera's 17 degrees
    window = read_openface(path, FPS, neutral=Neutral.parse("0-0.9"))
    np.testing.assert_allclose(window[48], (truth - np.median(truth[t <= 0.9])) / 1e-5, atol=1e-6)
    camera = read_openface(path, FPS, neutral=Neutral("none"))
    np.testing.assert_allclose(camera[48], truth / 1e-5, atol=1e-6)
    with pytest.raises(InputError, match="no usable frame in the calibration window 20-30 s"):
        read_openface(path, FPS, neutral=Neutral.parse("20-30"))


def _eyes_on_the_camera(n=240, vectors=True, offset=0.0):
    """A head turning +/- 20 degrees about ``offset`` radians 60 cm in front of the camera,
    both eyes fixed on it."""
    t = np.arange(n) / FPS
    ry = offset + 0.35 * np.sin(2 * np.pi * 0.25 * t)
    head_at = np.array([0.0, 0.0, 600.0])
    values = {"pose_Ry": ry, "pose_Tz": np.full(n, 600.0)}
    mean = np.zeros((n, 3))
    for eye, dx in (("0", -32.0), ("1", 32.0)):  # eye 0 is the leftmost in the image
        centre = head_at + np.column_stack(
            [dx * np.cos(ry), np.zeros(n), -dx * np.sin(ry)]
        )  # Ry turns the eye's offset about the head's centre
        gaze = -centre / np.linalg.norm(centre, axis=1, keepdims=True)
        mean += gaze / 2
        if vectors:
            for k, axis in enumerate("xyz"):
                values[f"gaze_{eye}_{axis}"] = gaze[:, k]
    values["gaze_angle_x"] = np.arctan2(mean[:, 0], -mean[:, 2])
    values["gaze_angle_y"] = np.arctan2(mean[:, 1], -mean[:, 2])
    return t, values


@pytest.mark.parametrize(("vectors", "offset"), [(True, 0.0), (False, 0.0), (True, -0.2)])
def test_eyes_that_stay_on_the_camera_turn_against_the_head(tmp_path, vectors, offset):
    """OpenFace's gaze is in camera coordinates: eyes fixed on the camera while the head turns
    must turn the other way in the head (stored as they were, the eyes did not move at all),
    also when the take's neutral is turned 11 degrees away from the camera."""
    t, values = _eyes_on_the_camera(vectors=vectors, offset=offset)
    track = read_openface(write_openface(tmp_path / "of.csv", t, values), FPS)
    head_yaw = track[49]
    assert np.ptp(head_yaw) > 0.6 / 1e-5  # +/- 20 degrees
    eyes = (track[23] + track[24]) / 2
    np.testing.assert_allclose(eyes, -head_yaw, atol=0.004 / 1e-5)  # 0.2 degrees
    # a left eye looking right of its axis, a right eye left of it: they converge on the lens
    assert (track[23] - track[24]).mean() < 0 if vectors else np.allclose(track[23], track[24])
    np.testing.assert_allclose(track[25], 0.0, atol=0.002 / 1e-5)


def test_lost_frames_are_filled_and_reported(tmp_path):
    t, keep, v = known_motion(drop=(40, 41, 150))  # 3 dropped frames
    success = np.ones(len(keep), int)
    success[100:105] = 0  # tracker lost the face for 5 frames
    conf = np.full(len(keep), 0.98)
    conf[200] = 0.3
    path = write_openface(
        tmp_path / "of.csv",
        t[keep],
        {k: c[keep] for k, c in v.items()},
        success=success,
        confidence=conf,
    )
    track = read_openface(path, FPS, neutral=Neutral("none"))
    report = track.metadata["capture"]
    assert report["invalid_samples"] == 6 and report["filled_frames"] == 9
    assert track.n_frames == 300
    # outside the gaps the nod is the whole take's; inside, a straight line between its ends
    whole = write_openface(tmp_path / "whole.csv", t, v)
    truth = read_openface(whole, FPS, neutral=Neutral("none"))[48]
    filled = np.r_[40, 41, 150, np.arange(100, 105) + 2, 200 + 3]
    outside = np.setdiff1d(np.arange(300), filled)
    np.testing.assert_allclose(track[48][outside], truth[outside], atol=60)
    np.testing.assert_allclose(track[48][filled], truth[filled], atol=600)


def test_a_gap_too_long_to_fill_names_its_rows(tmp_path):
    t, keep, v = known_motion()
    success = np.ones(300, int)
    success[60:90] = 0  # 1 s without a face
    path = write_openface(tmp_path / "of.csv", t, v, success=success)
    with pytest.raises(
        InputError,
        match=r"of.csv: no usable frame for 1\.00 s between rows "
        r"61 and 92",
    ):
        read_openface(path, FPS)


def test_29_97_fps_capture_is_placed_by_time_stamps(tmp_path):
    n = 600
    t = np.arange(n) / 29.97
    v = {"pose_Ry": 0.2 * np.sin(2 * np.pi * 0.25 * t)}
    track = read_openface(write_openface(tmp_path / "of.csv", t, v), FPS)
    assert track.metadata["capture"]["capture_fps"] == 29.97
    assert track.n_frames == 601  # 600 frames at 29.97 fps last 20.02 s
    truth = -0.2 * np.sin(2 * np.pi * 0.25 * track.times) / 1e-5
    np.testing.assert_allclose(track[49][:-1], truth[:-1], atol=150)


def test_missing_columns_are_reported_and_bad_rows_named(tmp_path):
    header = [
        "frame",
        "face_id",
        "timestamp",
        "confidence",
        "success",
        "pose_Tx",
        "pose_Ty",
        "pose_Tz",
        "pose_Rx",
        "pose_Ry",
        "pose_Rz",
    ]
    rows = [
        f"{k + 1}, 0, {k / 30:.3f}, 0.98, 1, 0.0, 0.0, 500.0, 0.010, 0.000, 0.000"
        for k in range(30)
    ]
    path = tmp_path / "pose_only.csv"
    path.write_text("\n".join([", ".join(header), *rows]) + "\n")
    track = read_openface(path, FPS)
    assert track.channels == (48, 49, 50)
    assert track.metadata["capture"]["missing"]["AU45_r"] == [19, 20, 21, 22]
    rows[4] = rows[4].replace("0.010", "abc")
    path.write_text("\n".join([", ".join(header), *rows]) + "\n")
    with pytest.raises(InputError, match=r"pose_only.csv:6: column pose_Rx: not a number"):
        read_openface(path, FPS)
    rows[4] = "5, 0, 0.133, 0.98"
    path.write_text("\n".join([", ".join(header), *rows]) + "\n")
    with pytest.raises(InputError, match=r":6: 4 values for 11 columns"):
        read_openface(path, FPS)


def test_cli_import_and_ground_truth_detection(tmp_path, repo_root):
    t, _, v = known_motion(n=150)
    src = write_openface(tmp_path / "take.csv", t, v)
    r = CliRunner().invoke(main, ["capture", "import", str(src), "--out", str(tmp_path / "gt.fap")])
    assert r.exit_code == 0, r.output
    assert "150 frames at 30 fps from 150 samples at 30 fps" in r.output
    assert "FAPs 3, 19, 20, 21, 22, 23, 24, 25, 26, 31" in r.output
    assert "head relative to the take's median pose (pitch 1.47, yaw -2.98, roll 0.03" in r.output
    assert "deg from the camera axis)" in r.output
    assert "gaze: turned from the camera's frame into the head's" in r.output
    r = CliRunner().invoke(
        main,
        ["capture", "import", str(src), "--out", str(tmp_path / "w.fap"), "--neutral", "1-2"],
    )
    assert r.exit_code == 0 and "head relative to the median pose over 1-2 s" in r.output
    assert load_track(tmp_path / "gt.fap").n_frames == 150
    assert load_track(src).channels == read_openface(src, FPS).channels  # by header
    out = tmp_path / "out"
    demo = repo_root / "app" / "data" / "demo" / "speech.wav"
    args = ["stimuli", "generate", "--audio", str(demo), "--ground-truth", str(src)]
    args += ["--out", str(out), "--no-plot", "--conditions", "ground_truth"]
    # a 5-s take for 4 s of speech: refused, unless the cut is asked for
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2 and "take.csv: ground truth: 5.00 s of motion for 4.00 s" in r.output
    r = CliRunner().invoke(main, [*args, "--pad"])
    assert r.exit_code == 0, r.output
    assert "of speech: its last 1.00 s are cut" in r.output
    assert load_track(out / "ground_truth.fap").n_frames == 120
    bad = CliRunner().invoke(
        main, ["capture", "import", str(repo_root / "README.md"), "--out", str(tmp_path / "x.fap")]
    )
    assert bad.exit_code == 2 and "not a file facepair imports (openface, arkit" in bad.output


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(st.text(alphabet="0123456789.,- abcn\n", max_size=40), max_size=12))
def test_junk_rows_are_one_input_error_never_a_crash(tmp_path, rows):
    path = tmp_path / "junk.csv"
    path.write_text(", ".join(openface_header(0)) + "\n" + "\n".join(rows))
    try:
        read_openface(path, FPS)
    except InputError as exc:
        assert "\n" not in str(exc)


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    st.lists(
        st.lists(
            st.sampled_from(["0", "1", "0.98", "-0.3", "3.2", "nan", "inf", "1e308"]),
            min_size=20,
            max_size=20,
        ),
        max_size=10,
    ),
    st.binary(max_size=100),
)
def test_any_numbers_or_bytes_are_a_track_or_one_input_error(tmp_path, rows, data):
    header = [
        "frame",
        "face_id",
        "timestamp",
        "confidence",
        "success",
        "gaze_0_x",
        "gaze_0_y",
        "gaze_0_z",
        "gaze_1_x",
        "gaze_1_y",
        "gaze_1_z",
        "gaze_angle_x",
        "gaze_angle_y",
        "pose_Rx",
        "pose_Ry",
        "pose_Rz",
        "AU01_r",
        "AU02_r",
        "AU04_r",
        "AU45_r",
    ]
    path = tmp_path / "numbers.csv"
    body = "\n".join(", ".join(r) for r in rows)
    path.write_bytes((", ".join(header) + "\n" + body + "\n").encode() + data)
    try:
        read_openface(path, FPS)
    except InputError as exc:
        assert "\n" not in str(exc) and "numbers.csv" in str(exc)


def test_a_take_looking_down_throughout_is_said_and_can_be_taken_out(tmp_path):
    """A real take's eyes sat 22 degrees down for its whole length (the camera below the
    eyes' line): reported, kept by default, taken out with gaze_neutral = "median"."""
    n = 240
    t = np.arange(n) / FPS
    down = np.radians(22.0) + 0.05 * np.sin(2 * np.pi * 0.5 * t)  # glances about 22 down
    values = {"pose_Tz": np.full(n, 600.0)}
    for eye in ("0", "1"):  # the camera frame: y down, z away from the camera
        values[f"gaze_{eye}_x"] = np.zeros(n)
        values[f"gaze_{eye}_y"] = np.sin(down)
        values[f"gaze_{eye}_z"] = -np.cos(down)
    values["gaze_angle_y"] = down
    path = write_openface(tmp_path / "of.csv", t, values)
    kept = read_openface(path, FPS)
    report = kept.metadata["capture"]
    assert report["gaze_offset"]["pitch_deg"] == pytest.approx(22.0, abs=0.3)
    assert abs(report["gaze_offset"]["yaw_deg"]) < 0.3
    assert np.degrees(np.median(kept[25]) * 1e-5) == pytest.approx(22.0, abs=0.3)  # + down
    warning = [w for w in report["warnings"] if w.startswith("the eyes look 22.0 deg down")]
    assert warning and "--gaze-neutral median takes it out" in warning[0]
    taken = read_openface(path, FPS, gaze_neutral="median")
    assert abs(np.median(taken[25])) < 1.0 and abs(np.median(taken[26])) < 1.0
    np.testing.assert_allclose(
        taken[25] - taken[25].mean(), kept[25] - kept[25].mean(), atol=1e-6
    )  # the glances stay
    r = CliRunner().invoke(main, ["capture", "import", str(path), "--out", str(tmp_path / "g.fap")])
    assert r.exit_code == 0 and "22 deg down" in r.output and "--gaze-neutral median" in r.output
    with pytest.raises(InputError, match="expected one of none, median"):
        read_openface(path, FPS, gaze_neutral="mean")
