import io
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.fapfile import high_level_note, read_fap, write_fap
from app.stimuli.track import MotionTrack


def mask(positions, n=68):
    """A mask line of ``n`` values with 1 at the given positions (counted from 1)."""
    bits = ["0"] * n
    for p in positions:
        bits[p - 1] = "1"
    return " ".join(bits)


def test_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(1)
    track = MotionTrack(
        25,
        np.rint(rng.normal(0, 3000, (50, 4))),
        (19, 31, 48, 49),
        name="a name with spaces",
        source="capture",
        speaker="s1",
    )
    path = tmp_path / "t.fap"
    write_fap(track, path)
    back = read_fap(path)
    assert back.equals(track)
    assert (back.name, back.source, back.speaker) == ("a name with spaces", "capture", "s1")
    write_fap(back, tmp_path / "u.fap")
    assert (tmp_path / "u.fap").read_text() == path.read_text()


# -- Greta's dialect: 69-value masks, FAP i at position i, one value per masked position --------

# One frame in Greta's layout: positions 3-13, 16-17, 41-42 and 51-63 masked, 28 values. The
# inner-lip FAPs 4-13 are mirrored by the outer-lip FAPs 51-60 (same signs, pairs equal), which
# holds only if position i is FAP i.
GRETA_LIPS = (
    "2.1 lips take.fap 25 1\n"
    # positions 1-10    11-20               21-30               31-40
    "0 0 1 1 1 1 1 1 1 1 1 1 1 0 0 1 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 "
    # 41-50             51-60               61-69
    "1 1 0 0 0 0 0 0 0 0 1 1 1 1 1 1 1 1 1 1 1 1 1 0 0 0 0 0 0 \n"
    "0 80 -43 -362 52 52 -43 -43 -362 -362 11 11 -5 -8 30 30 "
    "-34 -120 52 52 -34 -34 -120 -120 9 9 4 4 1 \n"
)


def test_greta_lip_pattern_lines_up_fap_i_with_position_i():
    t = read_fap(io.StringIO(GRETA_LIPS))
    assert t.channels == (*range(3, 14), 16, 17, 41, 42, *range(51, 64))
    assert t.n_frames == 1 and t.fps == 25 and t.name == "lips take.fap"
    assert (t[3][0], t[4][0], t[5][0], t[51][0], t[52][0]) == (80, -43, -362, -34, -120)
    for inner in range(4, 14):
        outer = inner + 47
        assert np.sign(t[inner][0]) == np.sign(t[outer][0]), (inner, outer)
    for left, right in [(6, 7), (8, 9), (10, 11), (12, 13), (53, 54), (55, 56), (57, 58)]:
        assert t[left][0] == t[right][0]
    assert t[6][0] == t[53][0] == 52
    assert (t[16][0], t[17][0], t[41][0], t[63][0]) == (-5, -8, 30, 1)


# Greta writes one integer for a masked viseme (position 1): here 3, then head_pitch -250.
GRETA_VISEME = (
    "2.1 hello.fap 25 1\n"
    "1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 "
    "0 0 0 0 0 0 0 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 \n"
    "0 3 -250 \n"
)


def test_greta_masked_viseme_carries_one_value_and_is_read_past():
    t = read_fap(io.StringIO(GRETA_VISEME))
    assert t.channels == (48,) and t[48].tolist() == [-250.0]
    only_viseme = "2.1 w.fap 25 1\n" + mask([1], 69) + " \n0 0 \n"
    t = read_fap(io.StringIO(only_viseme))
    assert t.channels == () and t.n_frames == 1


def test_greta_expression_and_trailing_extra_carry_one_value_each():
    text = f"2.1 g 30 2\n{mask([2, 50, 69], 69)}\n0 5 -900 1\n{mask([50], 69)}\n1 -700\n"
    t = read_fap(io.StringIO(text))
    assert t.channels == (50,) and t[50].tolist() == [-900.0, -700.0]


def test_greta_writer_writes_greta_layout_and_reads_back(tmp_path):
    track = MotionTrack(
        30, np.array([[1.0, -2.0, 3.0], [4.0, 5.0, -6.0]]), (3, 50, 68), source="capture"
    )
    path = tmp_path / "g.fap"
    write_fap(track, path, greta=True)
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    assert lines[1] == mask([3, 50, 68], 69)  # FAP i at position i, trailing extra 0
    assert lines[2] == "0 1 -2 3" and lines[4] == "1 4 5 -6"
    back = read_fap(path)
    assert back.equals(track) and back.source == "capture"
    write_fap(back, tmp_path / "h.fap", greta=True)
    assert (tmp_path / "h.fap").read_text() == path.read_text()


def test_early_facepair_greta_files_read_back_unchanged():
    # written by facepair's Greta option before Greta's layout was known: a null FAP 0 first,
    # then FAP 1..68 (FAP 3 at position 4, FAP 48 at 49, FAP 68 at 69)
    text = (
        "# MPEG-4 FAP stream written by facepair\n# source: capture\n# speaker: s1\n"
        "2.1 old take 25 2\n"
        "0 0 0 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 "
        "0 0 0 0 0 0 0 0 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 1\n"
        "0 120 -300 7\n"
        "0 0 0 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 "
        "0 0 0 0 0 0 0 0 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 1\n"
        "1 140 -250 9\n"
    )
    t = read_fap(io.StringIO(text))
    assert t.channels == (3, 48, 68)
    np.testing.assert_array_equal(t.values, [[120, -300, 7], [140, -250, 9]])
    assert (t.name, t.source, t.speaker) == ("old take", "capture", "s1")


# -- Xface's dialect: 68-value masks, MPEG-4 widths for FAP 1 and 2 ------------------------------

XFACE_WIDTH = {1: 4, 2: 6}


def xface_stream_read(text):
    """Frames as a reader in Xface's manner sees them: {index: {FAP: value}}, or None.

    After the header line the file is one stream of numbers: 68 mask values, the frame index,
    then 4 values for a masked FAP 1, 6 for FAP 2 and 1 for the others.
    """
    lines = [line for line in text.splitlines() if line.strip() and not line.startswith("#")]
    tokens = iter(" ".join(lines[1:]).split())
    frames = {}
    try:
        for _ in range(int(lines[0].split()[-1])):
            bits = [int(next(tokens)) for _ in range(68)]
            index = int(next(tokens))
            row = {}
            for fap, bit in enumerate(bits, start=1):
                if bit:
                    values = [int(next(tokens)) for _ in range(XFACE_WIDTH.get(fap, 1))]
                    if fap not in XFACE_WIDTH:
                        row[fap] = values[0]
            frames[index] = row
    except (StopIteration, ValueError):
        return None
    return frames


def test_default_output_is_xface_and_greta_output_is_not():
    track = MotionTrack(30, np.array([[10.0, 20.0, 30.0], [11.0, 21.0, 31.0]]), (3, 48, 68))
    expected = {0: {3: 10, 48: 20, 68: 30}, 1: {3: 11, 48: 21, 68: 31}}
    default, greta = io.StringIO(), io.StringIO()
    write_fap(track, default)
    write_fap(track, greta, greta=True)
    assert xface_stream_read(default.getvalue()) == expected
    assert xface_stream_read(greta.getvalue()) != expected  # 69 mask values desynchronise it
    assert read_fap(io.StringIO(greta.getvalue())).equals(track)


def test_xface_masked_viseme_carries_four_values():
    text = f"2.1 v 30 1\n{mask([1, 48])}\n0 12 13 50 1 -400\n"
    t = read_fap(io.StringIO(text))
    assert t.channels == (48,) and t[48].tolist() == [-400.0]
    assert xface_stream_read(text) == {0: {48: -400}}


def test_xface_masked_expression_carries_six_values():
    text = f"2.1 e 30 1\n{mask([2, 3])}\n0 1 40 2 60 0 1 250\n"
    t = read_fap(io.StringIO(text))
    assert t.channels == (3,) and t[3].tolist() == [250.0]
    assert xface_stream_read(text) == {0: {3: 250}}


def test_high_level_faps_are_read_past():
    text = f"2.1 v 30 1\n{mask([1, 2, 49])}\n0 1 2 50 0 1 2 3 4 5 6 -77\n"
    t = read_fap(io.StringIO(text))
    assert t.channels == (49,) and t[49].tolist() == [-77.0]


def test_missing_frames_and_masked_off_channels_are_interpolated():
    text = (
        "\n".join(
            [
                "# a comment",
                "2.1 gaps 10 5",
                mask([48, 49]),
                "0 0 100",
                mask([48]),
                "1 10",
                mask([48, 49]),
                "4 40 400",
            ]
        )
        + "\n"
    )
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
    "mask not binary": (
        f"2.1 x 25 1\n{mask([48]).replace('1', '2')}\n0 1\n",
        2,
        "expected only 0 and 1",
    ),
    "wrong value count": (
        f"2.1 x 25 1\n{mask([48, 49])}\n0 1\n",
        3,
        "expected the frame index and 2 values for the 2 masked positions",
    ),
    "Greta count in an Xface file": (
        f"2.1 x 25 1\n{mask([1, 48])}\n0 3 -250\n",
        3,
        "expected the frame index and 5 values for the 2 masked positions (68-value mask: "
        "Xface/MPEG-4, 4 values for FAP 1, 6 for FAP 2; Greta, one value each, would expect "
        "2), got 3 numbers",
    ),
    "MPEG-4 count in a Greta file": (
        f"2.1 x 25 1\n{mask([1, 2, 48], 69)}\n0 1 2 3 4 5 6 7 8 9 10 11 12\n",
        3,
        "expected the frame index and 3 values for the 3 masked positions (69-value mask: "
        "Greta, one value per masked position; Xface/MPEG-4, 4 for FAP 1 and 6 for FAP 2, "
        "would expect 11), got 13 numbers",
    ),
    "two dialects": (
        f"2.1 x 25 2\n{mask([48])}\n0 1\n{mask([48], 69)}\n1 2\n",
        4,
        "69 values after 68-value masks; a file holds one dialect",
    ),
    "value beyond 32 bits": (
        f"2.1 x 25 1\n{mask([48])}\n0 4294967296\n",
        3,
        "value 2 is outside the 32-bit integer range",
    ),
    "frame count beyond limit": (
        "2.1 x 25 99999999999\n",
        1,
        "frame count is 99999999999, expected 0..1000000",
    ),
    "negative index": (
        f"2.1 x 25 1\n{mask([48])}\n-1 5\n",
        3,
        "frame index -1: indices must start at >= 0",
    ),
    "non-number": (
        f"2.1 x 25 1\n{mask([48])}\n0 1.5\n",
        3,
        "value 2 is '1.5', expected an integer",
    ),
    "truncated pair": (
        f"2.1 x 25 2\n{mask([48])}\n0 1\n{mask([48])}\n",
        4,
        "truncated: a mask line without its value line",
    ),
    "truncated frames": (
        f"2.1 x 25 3\n{mask([48])}\n0 1\n",
        3,
        "truncated: header says 3 frames, the last frame index is 0",
    ),
    "index outside": (f"2.1 x 25 1\n{mask([48])}\n5 1\n", 3, "frame index 5 outside 0..0"),
    "index backwards": (
        f"2.1 x 25 3\n{mask([48])}\n1 1\n{mask([48])}\n0 1\n",
        5,
        "frame index 0 after 1: indices must start at >= 0 and increase",
    ),
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
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0
    assert f"{path}:3: value line: value 2 is 'oops', expected an integer" in proc.stderr
    assert "Traceback" not in proc.stderr


# -- any input: a track or the one-line input error, never another exception ----------------------


def _read_or_input_error(read, *args):
    try:
        return read(*args)
    except InputError as err:
        assert "\n" not in str(err) and str(err).strip()
        return None


@settings(max_examples=150, deadline=None)
@given(st.text())
def test_any_text_gives_a_track_or_one_line(text):
    _read_or_input_error(read_fap, io.StringIO(text))


@settings(max_examples=100, deadline=None)
@given(st.binary())
def test_any_bytes_give_a_track_or_one_line(data):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "any.fap"
        path.write_bytes(data)
        _read_or_input_error(read_fap, path)


frame_lines = st.tuples(
    st.sampled_from([67, 68, 69, 70]),
    st.sets(st.integers(1, 70), max_size=8),
    st.lists(st.integers(-(2**33), 2**33), max_size=14),
)


@settings(max_examples=200, deadline=None)
@given(
    n_frames=st.integers(0, 4),
    frames=st.lists(frame_lines, max_size=4),
    indices=st.lists(st.integers(-1, 5), max_size=4),
)
def test_near_miss_files_give_a_track_or_one_line(n_frames, frames, indices):
    lines = [f"2.1 fuzz 30 {n_frames}"]
    for k, (length, positions, values) in enumerate(frames):
        lines.append(mask([p for p in positions if p <= length], length))
        index = indices[k] if k < len(indices) else k
        lines.append(" ".join(map(str, [index, *values])))
    _read_or_input_error(read_fap, io.StringIO("\n".join(lines) + "\n"))


@settings(max_examples=150, deadline=None)
@given(greta=st.booleans(), n_frames=st.integers(1, 5), data=st.data())
def test_well_formed_files_of_either_dialect_keep_every_masked_low_level_fap(greta, n_frames, data):
    length = 69 if greta else 68
    lines, expected = [f"2.1 ok 25 {n_frames}"], {}
    for index in range(n_frames):
        positions = data.draw(st.sets(st.integers(1, length), max_size=10))
        values = []
        for p in sorted(positions):
            width = 1 if greta else XFACE_WIDTH.get(p, 1)
            drawn = data.draw(st.lists(st.integers(-5000, 5000), min_size=width, max_size=width))
            values += drawn
            if 3 <= p <= 68:
                expected.setdefault(p, {})[index] = drawn[0]
        lines += [mask(positions, length), " ".join(map(str, [index, *values]))]
    t = read_fap(io.StringIO("\n".join(lines) + "\n"))
    assert t.channels == tuple(sorted(expected))
    for fap, frames in expected.items():
        for index, value in frames.items():
            assert t[fap][index] == value


def test_cli_convert_writes_either_dialect(tmp_path):
    from click.testing import CliRunner

    from app.cli import main

    source = tmp_path / "lips.fap"
    source.write_text(GRETA_LIPS)
    runner = CliRunner()
    for flags, length in (([], 68), (["--greta"], 69)):
        target = tmp_path / f"out{length}.fap"
        r = runner.invoke(main, ["stimuli", "convert", str(source), str(target), *flags])
        assert r.exit_code == 0, r.output
        masks = [line for line in target.read_text().splitlines() if not line.startswith("#")]
        assert len(masks[1].split()) == length
        assert read_fap(target).equals(read_fap(source))
    r = runner.invoke(main, ["stimuli", "convert", str(source), str(tmp_path / "o.csv"), "--greta"])
    assert r.exit_code == 2 and "Greta's dialect is a .fap format, not .csv" in r.output


# -- FAP 1 (viseme) and FAP 2 (expression): kept with the track, written back ------------------


def body(text):
    """The header, mask and value lines of a .fap file (its comments aside)."""
    return [line.strip() for line in text.splitlines() if line.strip() and line[0] != "#"]


def test_a_greta_file_of_visemes_only_keeps_them_through_a_greta_rewrite():
    only_viseme = f"2.1 w.fap 25 3\n{mask([1], 69)}\n0 4\n{mask([1], 69)}\n1 9\n{mask([], 69)}\n2\n"
    track = read_fap(io.StringIO(only_viseme))
    assert track.channels == ()
    assert high_level_note(track) == (
        "FAP 1 (viseme) in 2 frames kept with the track: high-level, not motion, so not drawn"
    )
    out = io.StringIO()
    assert write_fap(track, out, greta=True) is None
    assert body(out.getvalue()) == body(only_viseme)


def test_greta_visemes_and_expressions_beside_motion_are_written_back_in_place():
    text = f"2.1 g 30 2\n{mask([1, 2, 48], 69)}\n0 3 5 -250\n{mask([2, 48], 69)}\n1 6 -200\n"
    track = read_fap(io.StringIO(text))
    assert track.channels == (48,) and track[48].tolist() == [-250.0, -200.0]
    assert track.metadata["high_level"]["frames"] == {"1": [[0, 3]], "2": [[0, 5], [1, 6]]}
    out = io.StringIO()
    write_fap(track, out, greta=True)
    assert body(out.getvalue()) == body(text)
    again = read_fap(io.StringIO(out.getvalue()))
    assert again.equals(track) and again.metadata == track.metadata


def test_xface_high_level_values_keep_their_widths_or_are_named_as_left_out():
    text = f"2.1 v 30 1\n{mask([1, 2, 49])}\n0 1 2 50 0 1 2 3 4 5 6 -77\n"
    track = read_fap(io.StringIO(text))
    xface = io.StringIO()
    assert write_fap(track, xface) is None
    assert body(xface.getvalue()) == body(text)
    greta = io.StringIO()
    note = write_fap(track, greta, greta=True)
    assert note == (
        "FAP 1 (viseme) and FAP 2 (expression) not written: they came with 4, 6 value(s) a "
        "frame, the 69-value mask: Greta, one value per masked position takes 1, 1"
    )
    assert f"# {note}" in greta.getvalue() and read_fap(io.StringIO(greta.getvalue())).equals(track)
    resampled = io.StringIO()
    note = write_fap(track.resample(60.0), resampled)
    assert note is not None and note.endswith("resampled, trimmed or padded after they were read")


def test_cli_greta_rewrite_keeps_the_viseme_mask(tmp_path):
    from click.testing import CliRunner

    from app.cli import main

    source = tmp_path / "hello.fap"
    source.write_text(GRETA_VISEME)
    target = tmp_path / "again.fap"
    r = CliRunner().invoke(main, ["stimuli", "convert", str(source), str(target), "--greta"])
    assert r.exit_code == 0, r.output
    assert body(target.read_text()) == body(GRETA_VISEME)


def test_cli_convert_says_which_high_level_faps_it_kept(tmp_path):
    from click.testing import CliRunner

    from app.cli import main

    source = tmp_path / "hello.fap"
    source.write_text(GRETA_VISEME)
    r = CliRunner().invoke(main, ["stimuli", "convert", str(source), str(tmp_path / "o.fap")])
    assert r.exit_code == 0, r.output
    notes = [ln for ln in r.output.splitlines() if ln.startswith("  note: ")]
    assert len(notes) == 1 and "FAP 1 (viseme)" in notes[0] and "kept" in notes[0], r.output
