"""The closed loop: known FAP tracks -> the marker look -> the capture -> the same tracks."""

from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from app.cli import main
from app.errors import InputError
from app.stimuli.capture.calibration import calibrate
from app.stimuli.capture.marker_faps import MarkerConstants
from app.stimuli.capture.markers import capture_markers, label_frames, tracks_to_faps
from app.stimuli.capture.video import read_grey_frames, video_info
from app.stimuli.io import load_track, save_track
from renderer.headmodel import builtin_face
from renderer.markers import (
    MarkerLook,
    calibration_motion,
    known_motion,
    marker_frames,
    write_marker_clip,
)
from tests.stimuli.capture.files import drop_video_frames

SIZE = 128  # small for speed; docs/reference/capture.md gives the 368 px figures
LOOK = MarkerLook(noise=2.0)


def captured(truth, seed):
    frames = marker_frames(truth, SIZE, look=replace(LOOK, seed=seed))
    return label_frames(zip(truth.times, frames, strict=True))


@pytest.fixture(scope="module")
def loop():
    face = builtin_face()
    base = MarkerConstants(squash=False, fapu_mm={k: face.fapu[k] for k in ("ENS0", "MNS0", "MW0")})
    known = calibration_motion(seconds=2.0)
    truth = known_motion(seconds=2.0)
    return base, calibrate(captured(known, 1), known, base), truth, captured(truth, 2)


def rms(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)))


def test_closed_loop_recovers_head_angles_and_eyebrows(loop):
    base, calibrated, truth, tracks = loop
    assert 0.06 < calibrated.kp < 0.09 and 0.025 < calibrated.ky < 0.045  # this head's frame
    rec = tracks_to_faps(tracks, constants=calibrated)
    for fap in (48, 49, 50):  # within 1 degree RMS
        assert np.degrees(rms(rec[fap], truth[fap]) * 1e-5) < 1.0, fap
    for fap in (31, 32, 33, 34):  # within 10 FAP units RMS
        assert rms(rec[fap], truth[fap]) < 10.0, fap
    # the thesis' constants belong to its camera and frame: on this head pitch is underrated
    thesis = tracks_to_faps(tracks, constants=base)
    assert np.degrees(rms(thesis[48], truth[48]) * 1e-5) > 2.0
    # without the calibrated pitch coupling, leaning moves the eyebrows
    uncoupled = replace(calibrated, brow_pitch_inner=0.0, brow_pitch_middle=0.0)
    assert rms(tracks_to_faps(tracks, constants=uncoupled)[33], truth[33]) > 10.0


def test_hidden_markers_are_recovered_and_reported(loop):
    base, calibrated, truth, _ = loop
    hidden = {"brow_middle_r": np.arange(30, 36), "lip_top": np.arange(40, 42)}
    frames = marker_frames(truth, SIZE, look=LOOK, hidden=hidden)
    tracks = label_frames(zip(truth.times, frames, strict=True))
    assert tracks.report["lost"] == {"brow_middle_r": 6, "lip_top": 2}
    rec = tracks_to_faps(tracks, constants=calibrated)
    assert rec.metadata["capture"]["marker_gaps"] == [
        ["brow_middle_r", 30, 35],
        ["lip_top", 40, 41],
    ]
    assert rms(rec[34], truth[34]) < 10.0


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    """A 29.97 fps marker video with frame 12 dropped by the card, and its known motion."""
    d = tmp_path_factory.mktemp("markers")
    truth = known_motion(fps=29.97, seconds=1.2)
    full = write_marker_clip(truth, d / "full.mp4", SIZE, look=LOOK)
    return truth, drop_video_frames(full, d / "dropped.mp4", [12]), full


def test_time_stamps_place_frames_and_the_cli_reports_the_drop(clip, tmp_path):
    truth, dropped, full = clip
    times = np.array([t for t, _ in read_grey_frames(dropped)])
    assert len(times) == truth.n_frames - 1
    np.testing.assert_allclose(np.diff(times)[11], 2 / 29.97, atol=1e-3)
    out = tmp_path / "rec.fap"
    r = CliRunner().invoke(
        main, ["capture", "markers", str(dropped), "--out", str(out), "--no-squash"]
    )
    assert r.exit_code == 0, r.output
    assert "from 35 video frames at 29.97 fps" in r.output
    assert "1 dropped frames filled" in r.output
    rec = load_track(out)
    assert rec.fps == 30.0 and rec.n_frames == 36
    resampled = np.interp(rec.times, truth.times, truth[50])
    assert np.degrees(rms(rec[50], resampled) * 1e-5) < 1.0  # roll needs no constants


def test_calibrate_command_writes_constants_markers_reads(tmp_path):
    known = calibration_motion(seconds=1.6)
    video = write_marker_clip(known, tmp_path / "cal.mp4", SIZE, look=LOOK)
    save_track(known, tmp_path / "known.csv")
    r = CliRunner().invoke(
        main,
        [
            "capture",
            "calibrate",
            str(video),
            "--truth",
            str(tmp_path / "known.csv"),
            "--out",
            str(tmp_path / "c.json"),
            "--fapu",
            "ENS0=51.9,MNS0=20.1",
        ],
    )
    assert r.exit_code == 0, r.output
    c = MarkerConstants.from_json(tmp_path / "c.json")
    assert 0.06 < c.kp < 0.09 and c.fapu_mm["ENS0"] == 51.9
    track = capture_markers(video, constants=c)
    assert np.degrees(rms(track[48], known[48]) * 1e-5) < 1.0


@pytest.mark.parametrize(
    ("hidden", "message"),
    [
        ({"cheek_l": [0]}, "frame 0 (0.000 s): marker cheek_l not found near"),
        ({"BR": range(5, 36)}, "marker BR lost from frame 5 (0.167 s) until the end"),
    ],
)
def test_unlabelable_videos_exit_2_naming_frame_and_marker(tmp_path, hidden, message):
    truth = known_motion(seconds=1.2)
    video = write_marker_clip(truth, tmp_path / "bad.mp4", SIZE, look=LOOK, hidden=hidden)
    r = CliRunner().invoke(
        main, ["capture", "markers", str(video), "--out", str(tmp_path / "x.fap")]
    )
    assert r.exit_code == 2
    last = r.output.strip().splitlines()[-1]
    assert last.startswith("facepair: error: ") and message in last and "Traceback" not in r.output


def test_bad_files_and_options_exit_2(tmp_path, repo_root):
    runner = CliRunner()
    for args, message in (
        ([str(repo_root / "README.md")], "not a video ffmpeg can read"),
        ([str(tmp_path / "none.mp4")], "video file not found"),
        ([str(repo_root / "README.md"), "--fapu", "ENS0=-3"], "--fapu: expected ENS0=mm"),
    ):
        r = runner.invoke(main, ["capture", "markers", *args, "--out", str(tmp_path / "x.fap")])
        assert r.exit_code == 2 and message in r.output, r.output
    with pytest.raises(InputError, match="not a video"):
        video_info(repo_root / "README.md")


@settings(max_examples=25, deadline=None)
@given(st.lists(st.binary(min_size=0, max_size=400), min_size=1, max_size=4))
def test_any_frames_are_labelled_or_refused_in_one_line(chunks):
    frames = [
        (k / 30.0, np.frombuffer(c.ljust(400, b"\0"), np.uint8).reshape(20, 20))
        for k, c in enumerate(chunks)
    ]
    try:
        tracks = label_frames(frames)
    except InputError as exc:
        assert "\n" not in str(exc)
    else:
        assert tracks.positions.shape == (len(frames), 17, 2)
