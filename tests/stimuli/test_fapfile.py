import io
import subprocess
import sys

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.fapfile import read_fap, write_fap
from app.stimuli.track import MotionTrack


def mask(faps, n=68):
    bits = ["0"] * n
    off = n - 68
    for f in faps:
        bits[f - 1 + off] = "1"
    return " ".join(bits)


def test_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(1)
    track = MotionTrack(25, np.rint(rng.normal(0, 3000, (50, 4))), (19, 31, 48, 49),
                        name="a name with spaces", source="capture", speaker="s1")
    path = tmp_path / "t.fap"
    write_fap(track, path)
    back = read_fap(path)
    assert back.equals(track)
    assert (back.name, back.source, back.speaker) == ("a name with spaces", "capture", "s1")
    write_fap(back, tmp_path / "u.fap")
    assert (tmp_path / "u.fap").read_text() == path.read_text()


def test_greta_69_value_masks_are_read(tmp_path):
    track = MotionTrack(30, np.array([[1.0, -2.0], [3.0, 4.0]]), (3, 50))
    buf = io.StringIO()
    write_fap(track, buf, greta=True)
    lines = buf.getvalue().splitlines()
    assert len(lines[-2].split()) == 69
    assert read_fap(io.StringIO(buf.getvalue())).equals(track)


def test_greta_null_fap_value_is_dropped():
    text = f"2.1 g 30 1\n{'1 ' + mask([48])}\n0 999 120\n"
    t = read_fap(io.StringIO(text))
    assert t.channels == (48,) and t[48].tolist() == [120.0]


def test_high_level_faps_are_read_past():
    text = f"2.1 v 30 1\n{mask([1, 2, 49])}\n0 1 2 50 0 1 2 3 4 5 6 -77\n"
    t = read_fap(io.StringIO(text))
    assert t.channels == (49,) and t[49].tolist() == [-77.0]


def test_missing_frames_and_masked_off_channels_are_interpolated():
    text = "\n".join([
        "# a comment", "2.1 gaps 10 5",
        mask([48, 49]), "0 0 100",
        mask([48]), "1 10",
        mask([48, 49]), "4 40 400",
    ]) + "\n"
    t = read_fap(io.StringIO(text))
    np.testing.assert_allclose(t[48], [0, 10, 20, 30, 40])
    np.testing.assert_allclose(t[49], [100, 175, 250, 325, 400])


def test_header_name_with_spaces_and_float_fps():
    t = read_fap(io.StringIO(f"2.1 my demo  take 2 29.97 1\n{mask([48])}\n0 5\n"))
    assert t.name == "my demo take 2" and t.fps == 29.97


CASES = {
    "empty": ("", None, "empty file"),
    "short header": ("2.1 30\n", 1, "expected '2.1 <name> <fps> <nframes>'"),
    "fps not a number": ("2.1 x abc 3\n", 1, "fps is 'abc', expected a number"),
    "fps zero": ("2.1 x 0 3\n", 1, "expected a number > 0"),
    "fps negative": ("2.1 x -25 3\n", 1, "expected a number > 0"),
    "frame count": ("2.1 x 25 many\n", 1, "frame count is 'many'"),
    "mask count": (f"2.1 x 25 1\n{'1 0 1'}\n0 1 2\n", 2, "expected 68 (Xface) or 69 (Greta)"),
    "mask not binary": (f"2.1 x 25 1\n{mask([48]).replace('1', '2')}\n0 1\n", 2,
                        "expected only 0 and 1"),
    "wrong value count": (f"2.1 x 25 1\n{mask([48, 49])}\n0 1\n", 3,
                          "expected the frame index and 2 values for the 2 masked FAPs, got 2"),
    "non-number": (f"2.1 x 25 1\n{mask([48])}\n0 1.5\n", 3,
                   "value 2 is '1.5', expected an integer"),
    "truncated pair": (f"2.1 x 25 2\n{mask([48])}\n0 1\n{mask([48])}\n", 4,
                       "truncated: a mask line without its value line"),
    "truncated frames": (f"2.1 x 25 3\n{mask([48])}\n0 1\n", 3,
                         "truncated: header says 3 frames, the last frame index is 0"),
    "index outside": (f"2.1 x 25 1\n{mask([48])}\n5 1\n", 3, "frame index 5 outside 0..0"),
    "index backwards": (f"2.1 x 25 3\n{mask([48])}\n1 1\n{mask([48])}\n0 1\n", 5,
                        "indices must increase"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_malformed_files_name_file_line_and_expectation(tmp_path, case):
    text, line, expected = CASES[case]
    path = tmp_path / "bad.fap"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        read_fap(path)
    message = str(err.value)
    assert expected in message
    prefix = f"{path}:{line}: " if line else f"{path}: "
    assert message.startswith(prefix), message


def test_binary_file_is_refused(tmp_path):
    path = tmp_path / "x.fap"
    path.write_bytes(b"\xff\xfe\x00\x01")
    with pytest.raises(InputError, match="not a text .fap file"):
        read_fap(path)


def test_cli_gives_exit_2_and_one_line(tmp_path):
    path = tmp_path / "bad.fap"
    path.write_text(f"2.1 x 25 1\n{mask([48])}\n0 oops\n")
    proc = subprocess.run(
        [sys.executable, "-m", "app", "stimuli", "convert", str(path), str(tmp_path / "o.csv")],
        capture_output=True, text=True,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0
    assert f"{path}:3: value line: value 2 is 'oops', expected an integer" in proc.stderr
    assert "Traceback" not in proc.stderr
