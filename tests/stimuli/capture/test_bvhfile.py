"""The strict BVH parser (``app.stimuli.capture.bvhfile``): a tiny file parsed to its skeleton
and motion, and one malformed file for each rule it enforces, refused with the line."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.capture.bvhfile import parse_bvh

# Two joints, an End Site and three frames of 6 + 3 channels; lines 19-21 are the frames.
TINY = """\
HIERARCHY
ROOT Hips
{
  OFFSET 0.0 90.0 0.0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Head
  {
    OFFSET 0 10.5 -1
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.04
1 2 3 4 5 6 7 8 9
-1 -2 -3 -4 -5 -6 -7 -8 -9
0.5 0 0 0 0 0 90 -45 1e2
"""
ROOT_CHANNELS = ["Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"]
MOTION = [
    [1, 2, 3, 4, 5, 6, 7, 8, 9],
    [-1, -2, -3, -4, -5, -6, -7, -8, -9],
    [0.5, 0, 0, 0, 0, 0, 90, -45, 100],
]


def write(tmp_path, text, name="bad.bvh"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_a_tiny_file_gives_its_skeleton_and_motion(tmp_path):
    skeleton = parse_bvh(write(tmp_path, TINY, "tiny.bvh"))
    hips, head = skeleton.joints
    assert (hips.name, hips.parent, hips.line, hips.first) == ("Hips", -1, 2, 0)
    assert hips.offset.tolist() == [0, 90, 0] and hips.end_site is None
    assert hips.channels == ROOT_CHANNELS
    assert (head.name, head.parent, head.line, head.first) == ("Head", 0, 6, 6)
    assert head.offset.tolist() == [0, 10.5, -1]
    assert head.channels == ["Zrotation", "Xrotation", "Yrotation"]
    assert head.end_site.tolist() == [0, 5, 0]
    assert skeleton.frame_time == 0.04
    assert skeleton.motion.shape == (3, 9) and skeleton.motion.tolist() == MOTION
    assert skeleton.lines.tolist() == [19, 20, 21]


def test_keywords_braces_line_ends_and_blank_lines_are_read_loosely(tmp_path):
    text = (
        "\ufeffhierarchy\r\n"
        "root Hips{ OFFSET 0 90 0 CHANNELS 6 " + " ".join(ROOT_CHANNELS) + "\r\n"
        "joint Head{OFFSET 0 10.5 -1 CHANNELS 3 zrotation xrotation yrotation"
        " end site{OFFSET 0 5 0}}}\r\n"
        "motion\r\n"
        "\r\n"
        "frames: 3\r\n"
        "frame   time: 0.04\r\n"
        "1 2 3 4 5 6 7 8 9\r\n"
        "\r\n"
        "-1 -2 -3 -4 -5 -6 -7 -8 -9\r\n"
        "0.5 0 0 0 0 0 90 -45 1e2\r\n"
    )
    skeleton = parse_bvh(write(tmp_path, text, "loose.bvh"))
    hips, head = skeleton.joints
    assert (hips.line, head.line, head.parent, head.first) == (2, 3, 0, 6)
    assert head.channels == ["zrotation", "xrotation", "yrotation"]
    assert head.end_site.tolist() == [0, 5, 0]
    assert skeleton.motion.tolist() == MOTION
    assert skeleton.lines.tolist() == [8, 10, 11]


def test_no_frames_is_an_empty_motion(tmp_path):
    text = TINY.split("1 2 3 4")[0].replace("Frames: 3", "Frames: 0")
    skeleton = parse_bvh(write(tmp_path, text, "still.bvh"))
    assert skeleton.motion.shape == (0, 9) and skeleton.lines.tolist() == []


@pytest.mark.parametrize(
    ("old", "new", "line", "message"),
    [
        ("HIERARCHY", "HIERARCH", 1, "expected HIERARCHY, got 'HIERARCH'"),
        ("ROOT Hips", "JOINT Hips", 2, "unexpected JOINT: one ROOT comes first"),
        ("JOINT Head", "ROOT Head", 6, "unexpected ROOT: one ROOT comes first"),
        ("ROOT Hips\n{", "ROOT Hips\n(", 3, "expected '{' after Hips"),
        ("End Site", "End Sight", 10, "expected 'End Site {' inside a joint"),
        ("OFFSET 0 5 0", "CHANNELS 0", 12, "expected OFFSET in an End Site"),
        ("OFFSET 0 5 0", "OFFSET 0 five 0", 12, "End Site OFFSET: 'five' is not a number"),
        ("OFFSET 0 5 0", "OFFSET 0 5 0 0", 12, "expected '}' closing the End Site"),
        ("HIERARCHY", "HIERARCHY OFFSET 0 0 0", 1, "OFFSET outside a joint, or twice"),
        (
            "OFFSET 0 10.5 -1",
            "OFFSET 0 10.5 -1 OFFSET 0 0 0",
            8,
            "OFFSET outside a joint, or twice",
        ),
        ("OFFSET 0.0 90.0 0.0", "OFFSET 0.0 ninety 0.0", 4, "OFFSET: 'ninety' is not a number"),
        ("OFFSET 0.0 90.0 0.0", "OFFSET 0.0 inf 0.0", 4, "OFFSET: 'inf' is not a finite number"),
        (
            "CHANNELS 3 Zrotation",
            "CHANNELS 7 Zrotation",
            9,
            "CHANNELS: expected a count 0-6 inside a joint, once",
        ),
        (
            "CHANNELS 3 Zrotation",
            "CHANNELS three Zrotation",
            9,
            "CHANNELS: expected a count 0-6 inside a joint, once",
        ),
        (
            "CHANNELS 3 Zrotation Xrotation Yrotation",
            "CHANNELS 1 Zrotation CHANNELS 2 Xrotation Yrotation",
            9,
            "CHANNELS: expected a count 0-6 inside a joint, once",
        ),
        (
            "HIERARCHY",
            "HIERARCHY CHANNELS 0",
            1,
            "CHANNELS: expected a count 0-6 inside a joint, once",
        ),
        (
            "3 Zrotation Xrotation Yrotation",
            "3 Zrotation zROTATION Yrotation",
            9,
            "CHANNELS: expected distinct X/Y/Z position/rotation, got "
            "Zrotation zROTATION Yrotation",
        ),
        (
            "3 Zrotation Xrotation Yrotation",
            "3 Zrotation Xrotation Wrotation",
            9,
            "CHANNELS: expected distinct X/Y/Z position/rotation, got "
            "Zrotation Xrotation Wrotation",
        ),
        ("HIERARCHY", "HIERARCHY }", 1, "'}' closes no joint"),
        ("    OFFSET 0 10.5 -1\n", "\n", 14, "joint Head has no OFFSET"),
        ("  JOINT Head", "  JOIN Head", 6, "unexpected 'JOIN' in the hierarchy"),
        ("MOTION", "MOTIONS", 16, "expected MOTION after the hierarchy, got 'MOTIONS'"),
        ("Frames: 3", "Frame: 3", 17, "expected 'Frames: <value>', got 'Frame: 3'"),
        ("Frames: 3", "Frames:", 17, "expected 'Frames: <value>', got 'Frames:'"),
        ("Frames: 3", "Frames: -3", 17, "Frames: expected 0..1000000, got '-3'"),
        ("Frames: 3", "Frames: 1000001", 17, "Frames: expected 0..1000000, got '1000001'"),
        (
            "Frame Time: 0.04",
            "Frame Tim: 0.04",
            18,
            "expected 'Frame Time: <value>', got 'Frame Tim: 0.04'",
        ),
        ("Frame Time: 0.04", "Frame Time: fast", 18, "Frame Time: 'fast' is not a number"),
        ("Frame Time: 0.04", "Frame Time: nan", 18, "Frame Time: 'nan' is not a finite number"),
        ("Frame Time: 0.04", "Frame Time: 0", 18, "Frame Time: expected seconds > 0"),
        ("Frames: 3", "Frames: 4", 21, "Frames says 4, the file has 3 frame lines (truncated)"),
        ("Frames: 3", "Frames: 2", 21, "Frames says 2, the file has 3 frame lines"),
        ("-1 -2 -3 -4 -5 -6 -7 -8 -9", "-1 -2 -3 -4 -5 -6 -7 -8", 20, "8 values for 9 channels"),
        ("0.5 0 0", "0.5 zero 0", 21, "'zero' is not a number"),
        ("1e2", "1e999", 21, "a value is not a finite number"),
    ],
)
def test_each_malformed_line_is_one_input_error_naming_it(tmp_path, old, new, line, message):
    assert old in TINY
    path = write(tmp_path, TINY.replace(old, new, 1))
    with pytest.raises(InputError) as caught:
        parse_bvh(path)
    assert str(caught.value) == f"{path}:{line}: {message}"
    assert (caught.value.path, caught.value.line) == (str(path), line)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "the file ends inside the hierarchy: expected HIERARCHY"),
        (
            TINY.split("  JOINT")[0],
            "the file ends inside the hierarchy: expected a joint, OFFSET, CHANNELS or '}'",
        ),
        (TINY.split("MOTION")[0], "the file ends inside the hierarchy: expected MOTION"),
        (TINY.split("Frames")[0], "expected 'Frames:' and 'Frame Time:' after MOTION"),
        (TINY.split("Frame Time")[0], "expected 'Frames:' and 'Frame Time:' after MOTION"),
    ],
    ids=["empty", "in-a-joint", "no-motion", "motion-only", "no-frame-time"],
)
def test_a_file_cut_short_is_one_input_error_naming_the_file(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(InputError) as caught:
        parse_bvh(path)
    assert str(caught.value) == f"{path}: {message}"
    assert caught.value.line is None


def test_a_missing_frame_line_names_the_frame_time_line(tmp_path):
    path = write(tmp_path, TINY.split("1 2 3 4")[0].replace("Frames: 3", "Frames: 1"))
    with pytest.raises(InputError) as caught:
        parse_bvh(path)
    assert str(caught.value) == f"{path}:18: Frames says 1, the file has 0 frame lines (truncated)"


def _many_joints(children: int) -> str:
    # the root on line 2, its OFFSET on line 3, child k on line 3 + k
    lines = ["HIERARCHY", "ROOT r {", "OFFSET 0 0 0"]
    lines += [f"JOINT j{k} {{ OFFSET 0 0 0 }}" for k in range(1, children + 1)]
    return "\n".join([*lines, "}", "MOTION", "Frames: 0", "Frame Time: 1", ""])


def test_at_most_2000_joints(tmp_path):
    assert len(parse_bvh(write(tmp_path, _many_joints(1999), "most.bvh")).joints) == 2000
    path = write(tmp_path, _many_joints(2000))
    with pytest.raises(InputError) as caught:
        parse_bvh(path)
    assert str(caught.value) == f"{path}:2003: more than 2000 joints"


def test_unreadable_files_are_one_input_error(tmp_path):
    missing = tmp_path / "missing.bvh"
    with pytest.raises(InputError) as caught:
        parse_bvh(missing)
    assert str(caught.value) == f"{missing}: no such file"
    binary = tmp_path / "binary.bvh"
    binary.write_bytes(b"HIERARCHY\n\xff\xfe ROOT")
    with pytest.raises(InputError) as caught:
        parse_bvh(binary)
    assert str(caught.value) == f"{binary}: not a text BVH file (not UTF-8)"
    with pytest.raises(InputError) as caught:
        parse_bvh(tmp_path)
    assert str(caught.value) == f"{tmp_path}: cannot read: Is a directory"


_LINES = TINY.splitlines()
_EDITS = st.lists(
    st.tuples(
        st.integers(0, len(_LINES) - 1),
        st.one_of(
            st.none(),  # delete the line
            st.just(True),  # repeat it
            st.sampled_from(["", "{", "}", "End Site", "JOINT J", "CHANNELS 2", "OFFSET 1", "1 2"]),
            st.lists(st.floats(allow_nan=False), min_size=9, max_size=9).map(
                lambda values: " ".join(map(repr, values))  # a frame line, finite or not
            ),
            st.text(st.characters(exclude_categories=["Cs"]), max_size=12),
        ),
    ),
    min_size=1,
    max_size=4,
)


@settings(
    max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(_EDITS)
def test_any_edited_file_is_a_skeleton_or_one_input_error(tmp_path, edits):
    """Whatever the text, the parser gives a consistent skeleton or its own error, never
    another exception."""
    lines = list(_LINES)
    for index, edit in edits:
        k = min(index, len(lines) - 1)
        if not lines:
            break
        if edit is None:
            del lines[k]
        elif edit is True:
            lines.insert(k, lines[k])
        else:
            lines[k] = edit
    path = write(tmp_path, "\n".join(lines) + "\n", "edited.bvh")
    n_lines = len(path.read_text(encoding="utf-8-sig").splitlines())
    try:
        skeleton = parse_bvh(path)
    except InputError as exc:
        assert exc.path == str(path) and "\n" not in str(exc)
        assert exc.line is None or 1 <= exc.line <= n_lines
        return
    n_channels = sum(len(j.channels) for j in skeleton.joints)
    assert skeleton.motion.shape == (len(skeleton.lines), n_channels)
    assert np.all(np.isfinite(skeleton.motion)) and skeleton.frame_time > 0
    assert all(1 <= line <= n_lines for line in skeleton.lines)
    assert [j.first for j in skeleton.joints] == list(
        np.cumsum([0] + [len(j.channels) for j in skeleton.joints])[:-1]
    )
