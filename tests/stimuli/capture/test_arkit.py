import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cli import main
from app.errors import InputError
from app.stimuli.capture import sniff_csv
from app.stimuli.capture.arkit import (
    HEADER,
    arkit_mapping,
    read_arkit_csv,
    write_arkit_csv,
)
from tests.stimuli.capture.files import write_live_link


def take(n=240, app_fps=60):
    t = np.arange(n) / app_fps
    return t, {
        "HeadPitch": 0.08 * np.sin(2 * np.pi * 0.5 * t),
        "HeadYaw": 0.2 * np.sin(2 * np.pi * 0.25 * t),
        "HeadRoll": np.full(n, -0.03),
        "LeftEyeYaw": np.full(n, 0.1),
        "RightEyeYaw": np.full(n, 0.1),
        "LeftEyePitch": np.full(n, 0.05),
        "RightEyePitch": np.full(n, 0.05),
        "BrowInnerUp": np.where((t % 2) < 1, 0.4, 0.0),
        "BrowOuterUpLeft": np.full(n, 0.2),
        "BrowOuterUpRight": np.full(n, 0.1),
        "BrowDownLeft": np.zeros(n),
        "BrowDownRight": np.zeros(n),
        "EyeBlinkLeft": np.where((t % 2) > 1.8, 1.0, 0.0),
        "EyeBlinkRight": np.where((t % 2) > 1.8, 1.0, 0.0),
        "JawOpen": np.full(n, 0.25),
    }


def test_a_live_link_take_maps_to_faps(tmp_path):
    t, v = take()
    path = write_live_link(tmp_path / "take.csv", 240, v)
    assert sniff_csv(path) == "arkit"
    # the table itself: coefficients as recorded (the take's rest: its own test, below)
    track = read_arkit_csv(path, 30.0, brow_neutral="none")
    report = track.metadata["capture"]
    assert report["app_fps"] == 60 and report["capture_fps"] == 60
    assert track.n_frames == 120  # 4 s at 30 fps
    truth = 0.2 * np.sin(2 * np.pi * 0.25 * track.times) / 1e-5  # radians -> AU
    np.testing.assert_allclose(track[49][2:-2], truth[2:-2], atol=30)
    np.testing.assert_allclose(track[50], -3000.0, atol=1)
    np.testing.assert_allclose(track[23], 10000.0, atol=1)
    raised = track[31][track[31] > 20]
    assert np.median(raised) == pytest.approx(40.0, abs=0.5)  # a 0.4 inner raise: 40 units
    assert track[35].min() == pytest.approx(20.0, abs=1) and track[36].min() == pytest.approx(
        10.0, abs=1
    )
    assert track[19].max() == pytest.approx(0.8 * 1024, rel=0.01)
    np.testing.assert_allclose(track[3], 200.0, atol=1e-6)


def test_dropped_frames_are_filled_and_flip_turns_an_axis(tmp_path):
    t, v = take()
    path = write_live_link(tmp_path / "take.csv", 240, v, drop=(50, 51, 52))
    track = read_arkit_csv(path, 30.0)
    assert track.metadata["capture"]["filled_frames"] == 3
    flipped = read_arkit_csv(path, 30.0, mapping=arkit_mapping(flip=["headpitch"]))
    np.testing.assert_allclose(flipped[48], -track[48])
    np.testing.assert_allclose(flipped[49], track[49])


def test_round_trip_through_the_writer(tmp_path):
    t, v = take(app_fps=30, n=120)
    written = write_live_link(tmp_path / "a.csv", 120, v, app_fps=30)
    first = read_arkit_csv(written, 30.0, brow_neutral="none")
    write_arkit_csv(first, tmp_path / "b.csv")
    assert (tmp_path / "b.csv").read_text().splitlines()[0] == ",".join(HEADER)
    again = read_arkit_csv(tmp_path / "b.csv", 30.0, brow_neutral="none")
    assert again.channels == first.channels
    for c in first.channels:
        # six decimals of radians are 0.1 AU; of blendshapes, 1e-4 FAP units
        np.testing.assert_allclose(again[c], first[c], atol=0.1, err_msg=str(c))


def test_malformed_rows_name_row_and_column(tmp_path):
    t, v = take(n=30)
    path = write_live_link(tmp_path / "take.csv", 30, v)
    lines = path.read_text().splitlines()
    cells = lines[5].split(",")
    cells[HEADER.index("JawOpen")] = "open"
    lines[5] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"take.csv:6: column JawOpen: not a number: 'open'"):
        read_arkit_csv(path)
    lines[5] = "yesterday," + ",".join(cells[1:])
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"take.csv:6: column Timecode: expected HH:MM:SS:FF"):
        read_arkit_csv(path)


def test_cli_import_and_export(tmp_path):
    t, v = take()
    src = write_live_link(tmp_path / "take.csv", 240, v, drop=(10,))
    r = CliRunner().invoke(
        main,
        ["capture", "import", str(src), "--out", str(tmp_path / "gt.fap"), "--flip", "HeadPitch"],
    )
    assert r.exit_code == 0, r.output
    assert "120 frames at 30 fps from 239 samples at 60 fps" in r.output
    assert "1 frames filled by interpolation" in r.output
    r = CliRunner().invoke(
        main, ["capture", "export", str(tmp_path / "gt.fap"), "--out", str(tmp_path / "back.csv")]
    )
    assert r.exit_code == 0 and sniff_csv(tmp_path / "back.csv") == "arkit"
    bad = CliRunner().invoke(
        main, ["capture", "import", str(src), "--out", str(tmp_path / "x.fap"), "--flip", "Nose"]
    )
    assert bad.exit_code == 2 and "--flip takes ARKit rotation columns" in bad.output


def test_arkit_weights_of_one_frame_equal_those_of_the_track():
    """The avatar's per-frame weights and the CSV writer's columns come from one table."""
    from app.stimuli.capture.arkit import arkit_weights

    rng = np.random.default_rng(3)
    dense = rng.uniform(-150, 150, (5, 68))
    frames = [arkit_weights(row) for row in dense]
    whole = arkit_weights(dense)
    for name, column in whole.items():
        assert np.allclose(column, [f[name] for f in frames])
    assert np.allclose(whole["JawOpen"], dense[:, 2] / 800.0)
    assert np.allclose(whole["HeadYaw"], dense[:, 48] * 1e-5)


def write_subframe_take(path, n, values, early=()):
    """A take whose frames in ``early`` were stamped a hair before their time: the app writes
    frame 45 as ``44.999`` and frame 46 as ``46.000`` (60 fps)."""
    lines = [",".join(HEADER)]
    for k in range(n):
        frames = k - (0.0004 if k in early else 0.0)
        whole = int(np.floor(frames))
        secs, ff = divmod(whole, 60)
        fraction = int((frames - whole) * 1000)  # the app truncates to 3 digits
        stamp = f"10:20:{secs:02d}:{ff:02d}.{fraction:03d}"
        cells = [f"{float(values[h][k]) if h in values else 0.0:.8f}" for h in HEADER[2:]]
        lines.append(",".join([stamp, "61", *cells]))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_subframe_rounding_of_timecodes_is_not_a_gap(tmp_path):
    t, v = take()
    path = write_subframe_take(tmp_path / "take.csv", 240, v, early=(45, 107, 190))
    assert "00:44.999" in path.read_text() and "00:46.000" in path.read_text()
    track = read_arkit_csv(path, 30.0)
    report = track.metadata["capture"]
    assert report["filled_frames"] == 0 and report["gaps"] == [] and report["duplicates"] == 0
    assert report["capture_fps"] == 60 and report["timecode"].endswith("sub-frame fractions")
    truth = 0.2 * np.sin(2 * np.pi * 0.25 * track.times) / 1e-5
    np.testing.assert_allclose(track[49][2:-2], truth[2:-2], atol=30)
    # a frame really dropped is still one
    lines = path.read_text().splitlines()
    del lines[1 + 150]
    path.write_text("\n".join(lines) + "\n")
    dropped = read_arkit_csv(path, 30.0).metadata["capture"]
    assert dropped["filled_frames"] == 1 and dropped["gaps"] == [[2.5, 2.517]]
    # digits that count something else (not fractions) leave the frame numbers alone
    counter = write_live_link(tmp_path / "counter.csv", 240, v)
    report = read_arkit_csv(counter, 30.0).metadata["capture"]
    assert report["timecode"] == "frame numbers" and report["filled_frames"] == 0


def test_columns_that_are_zero_in_every_frame_are_left_out_with_a_warning(tmp_path):
    t, v = take()
    for name in ("HeadYaw", "HeadPitch", "HeadRoll"):
        v[name] = np.zeros(240)  # recorded with head rotation off
    path = write_live_link(tmp_path / "take.csv", 240, v)
    track = read_arkit_csv(path, 30.0, brow_neutral="none")
    assert not {48, 49, 50} & set(track.channels) and 3 in track.channels
    report = track.metadata["capture"]
    assert report["left_out"] == [48, 49, 50]
    assert report["constant"]["HeadYaw"] == 0.0 and report["constant"]["JawOpen"] == 0.25
    assert len(report["warnings"]) == 2 and all("\n" not in w for w in report["warnings"])
    assert report["warnings"][1].startswith("FAP 48, 49, 50 left out")
    out = ["--out", str(tmp_path / "g.fap"), "--brow-neutral", "none"]
    r = CliRunner().invoke(main, ["capture", "import", str(path), *out])
    assert r.exit_code == 0, r.output
    assert "constant in every frame: " in r.output and "HeadPitch = 0" in r.output
    assert "FAP 48, 49, 50 left out: their columns are 0 in every frame" in r.output


_STAMP = st.builds(
    lambda h, m, s, f, d: f"{h:02d}:{m:02d}:{s:02d}:{f:02d}" + (f".{d}" if d else ""),
    st.integers(0, 99999),
    st.integers(0, 99),
    st.integers(0, 99),
    st.integers(0, 999),
    st.text(alphabet="0123456789", max_size=4),
)


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    st.lists(
        st.tuples(
            _STAMP,
            st.lists(
                st.sampled_from(["0", "0.5", "-1", "nan", "inf", "1e308", "x"]),
                min_size=61,
                max_size=61,
            ),
        ),
        max_size=8,
    ),
    st.lists(st.text(alphabet="0123456789.,:- abx\n", max_size=30), max_size=4),
)
def test_junk_rows_are_one_input_error_never_a_crash(tmp_path, rows, junk):
    path = tmp_path / "junk.csv"
    lines = [",".join(HEADER), *(",".join([stamp, "61", *cells]) for stamp, cells in rows), *junk]
    path.write_text("\n".join(lines))
    try:
        read_arkit_csv(path)
    except InputError as exc:
        assert "\n" not in str(exc) and "junk.csv" in str(exc)


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.binary(max_size=300))
def test_any_bytes_are_a_track_or_one_input_error(tmp_path, data):
    path = tmp_path / "bytes.csv"
    path.write_bytes(b"Timecode,BlendShapeCount,JawOpen,HeadYaw\n" + data)
    assert sniff_csv(path) in ("arkit", None)
    try:
        read_arkit_csv(path)
    except InputError as exc:
        assert "\n" not in str(exc) and "bytes.csv" in str(exc)


def test_a_take_in_openfacefx_layout_reads_by_column_name(tmp_path):
    """OpenFaceFX's hello.arkit.csv: JawLeft before JawRight, MouthLeft before MouthRight,
    HH:MM:SS:FF timecodes without digits after a point, rotations all 0 (a speech-driven
    tool writes no head)."""
    order = list(HEADER)
    for a, b in (("JawRight", "JawLeft"), ("MouthRight", "MouthLeft")):
        i, j = order.index(a), order.index(b)
        order[i], order[j] = order[j], order[i]
    t, v = take(n=120, app_fps=60)
    for name in ("HeadYaw", "HeadPitch", "HeadRoll", "LeftEyeYaw", "RightEyeYaw"):
        v[name] = np.zeros(120)
    v["LeftEyePitch"] = v["RightEyePitch"] = np.zeros(120)
    lines = [",".join(order)]
    for k in range(120):
        cells = [f"{float(v[h][k]) if h in v else 0.0:.6f}" for h in order[2:]]
        lines.append(",".join([f"00:00:{k // 60:02d}:{k % 60:02d}", "61", *cells]))
    path = tmp_path / "hello.arkit.csv"
    path.write_text("\n".join(lines) + "\n")
    track = read_arkit_csv(path, 30.0)
    report = track.metadata["capture"]
    assert report["timecode"] == "frame numbers" and report["filled_frames"] == 0
    assert report["left_out"] == [48, 49, 50, 23, 24, 25, 26]
    np.testing.assert_allclose(track[3], 200.0, atol=1e-6)  # JawOpen 0.25, found by name


def test_samples_twice_a_timecode_frame_are_placed_by_their_fractions(tmp_path):
    """ARKit at 60 Hz under 30 fps timecodes: frames 00.000, 00.500, 01.000, ... Read by frame
    number alone, every other sample was a duplicate and half the take was dropped."""
    t, v = take(n=240, app_fps=60)
    lines = [",".join(HEADER)]
    for k in range(240):
        secs, half = divmod(k, 60)
        ff, sub = divmod(half, 2)
        cells = [f"{float(v[h][k]) if h in v else 0.0:.8f}" for h in HEADER[2:]]
        lines.append(",".join([f"09:00:{secs:02d}:{ff:02d}.{sub * 5}00", "61", *cells]))
    path = tmp_path / "take.csv"
    path.write_text("\n".join(lines) + "\n")
    report = read_arkit_csv(path, 30.0, app_fps=30.0).metadata["capture"]
    assert report["capture_fps"] == 60 and report["duplicates"] == 0
    assert report["samples"] == 240 and report["filled_frames"] == 0


def test_brows_are_taken_from_the_takes_rest_and_said(tmp_path):
    """A real take held BrowDown at 0.2-0.3 throughout: imported as recorded, its brows were
    furrowed in every frame. Relative to the take's median they rest at 0 and keep their
    raises."""
    n = 240
    t = np.arange(n) / 60.0
    raise_ = np.where((t > 1.0) & (t < 1.6), 0.35, 0.0)  # one inner raise of 0.35
    values = {
        "BrowDownLeft": np.full(n, 0.25),
        "BrowDownRight": np.full(n, 0.22),
        "BrowInnerUp": 0.05 + raise_,
        "JawOpen": 0.2 + 0.1 * np.sin(6 * t),
    }
    path = write_live_link(tmp_path / "take.csv", n, values)
    as_recorded = read_arkit_csv(path, 30.0, brow_neutral="none")
    assert np.median(as_recorded[31]) == pytest.approx(5 - 25, abs=1)  # furrowed throughout
    track = read_arkit_csv(path, 30.0)
    assert np.median(track[31]) == pytest.approx(0.0, abs=0.5)
    assert track[31].max() == pytest.approx(35.0, abs=2.0)  # the raise (a spline overshoots 1)
    report = track.metadata["capture"]
    assert report["brow_rest"]["BrowDownLeft"] == pytest.approx(0.25)
    said = [w for w in report["warnings"] if w.startswith("brows relative to the take's rest")]
    assert said == [
        "brows relative to the take's rest (median BrowDownLeft 0.25, BrowDownRight 0.22, "
        "BrowInnerUp 0.05); --brow-neutral none keeps them as recorded"
    ]
    r = CliRunner().invoke(main, ["capture", "import", str(path), "--out", str(tmp_path / "g.fap")])
    assert r.exit_code == 0 and "brows relative to the take's rest" in r.output
    bad = CliRunner().invoke(
        main,
        ["capture", "import", str(path), "--out", str(tmp_path / "g.fap"), "--brow-neutral", "x"],
    )
    assert bad.exit_code == 2


def test_a_frame_stamped_early_is_no_gap(tmp_path):
    """The app stores a frame a hair early: 42.999, 43.999, 44.999, then 46.000. Read by the
    frame numbers alone that was a one-frame gap (44 to 46) which is not there."""
    from app.stimuli.capture.arkit import HEADER

    lines = [",".join(HEADER)]
    stamps = [f"14:03:52:{k:02d}.999" for k in range(30, 45)] + [
        f"14:03:52:{k:02d}.000" for k in range(46, 60)
    ]
    for k, stamp in enumerate(stamps):
        row = [stamp, "61"] + ["0.0"] * (len(HEADER) - 2)
        row[HEADER.index("JawOpen")] = f"{0.1 + 0.01 * k:.8f}"
        lines.append(",".join(row))
    path = tmp_path / "early.csv"
    path.write_text("\n".join(lines) + "\n")
    report = read_arkit_csv(path, 30.0).metadata["capture"]
    assert report["filled_frames"] == 0 and report["invalid_samples"] == 0, report
    assert report["timecode"] == "frame numbers and their sub-frame fractions"
