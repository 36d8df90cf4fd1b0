"""Live Link Face timecodes: frame numbers, and the digits after the point when they are
fractions of a frame."""

import pytest

from app.stimuli.capture.timecode import frame_times, parse_timecode, timecode_problem


def test_timecodes():
    assert parse_timecode("14:03:52:28.207", 60) == pytest.approx(14 * 3600 + 3 * 60 + 52 + 28 / 60)
    with pytest.raises(ValueError, match="expected a timecode"):
        parse_timecode("14:03:52", 60)


@pytest.mark.parametrize(
    ("text", "fps", "seconds"),
    [
        ("01:02:03:15", 30, 3600 + 2 * 60 + 3 + 0.5),
        ("00:00:00:30.999", 60, 0.5),  # the digits after the point are not used
        (" 00:00:01:00 \n", 60, 1.0),
        ("00:00:00:100", 120, 100 / 120),
    ],
)
def test_a_timecode_is_its_frames_seconds(text, fps, seconds):
    assert parse_timecode(text, fps) == pytest.approx(seconds)


@pytest.mark.parametrize("text", ["00:00:01", "aa:00:00:00", "00:00:00:00.", "00:00:00:1000"])
def test_anything_else_is_refused_with_the_text(text):
    with pytest.raises(ValueError) as caught:
        parse_timecode(text, 60)
    assert str(caught.value) == f"expected a timecode HH:MM:SS:FF(.sss), got {text!r}"


def test_timecode_problem_says_why_or_nothing():
    assert timecode_problem("00:00:01:02") is None
    assert timecode_problem("00:00:01:02.507") is None
    assert timecode_problem("1:2:3") == "expected HH:MM:SS:FF(.sss), got '1:2:3'"
    assert timecode_problem("x" * 50) == f"expected HH:MM:SS:FF(.sss), got {'x' * 40!r}"


def test_frame_numbers_alone_without_digits_after_the_point():
    times, fraction = frame_times(["00:00:01:00", "00:00:01:01", "00:00:01:02"], 30)
    assert times.tolist() == pytest.approx([1.0, 1 + 1 / 30, 1 + 2 / 30], abs=1e-9) and not fraction
    times, fraction = frame_times(["00:00:00:10.500"], 60)  # one stamp: nothing to compare
    assert times.tolist() == pytest.approx([10 / 60], abs=1e-9) and not fraction


def test_a_running_counter_after_the_point_is_no_fraction():
    # both readings step by whole frames: the tie keeps the frame numbers alone
    stamps = ["00:00:00:01.001", "00:00:00:02.002", "00:00:00:03.003", "00:00:00:04.004"]
    times, fraction = frame_times(stamps, 60)
    assert (
        times.tolist() == pytest.approx([1 / 60, 2 / 60, 3 / 60, 4 / 60], abs=1e-9) and not fraction
    )


def test_a_sub_frame_fraction_is_used_when_it_skips_fewer_frames():
    # frame numbers alone: steps of 1, 1 and 2 frames; with the fraction: 1, 1 and 1.001
    stamps = ["00:00:02:04.999", "00:00:02:05.999", "00:00:02:06.999", "00:00:02:08.000"]
    times, fraction = frame_times(stamps, 30)
    assert fraction
    assert times.tolist() == pytest.approx(
        [2 + n / 30 for n in (4.999, 5.999, 6.999, 8.0)], abs=1e-9
    )


def test_a_fraction_that_breaks_whole_frame_steps_is_not_used():
    # frame numbers alone: steps of 1, 1 and 2 frames; with the fraction: 1, 0.999 and 1.501
    stamps = ["10:00:00:10.500", "10:00:00:11.500", "10:00:00:12.499", "10:00:00:14.000"]
    times, fraction = frame_times(stamps, 30)
    assert not fraction
    assert times.tolist() == pytest.approx([36000 + n / 30 for n in (10, 11, 12, 14)], abs=1e-9)
