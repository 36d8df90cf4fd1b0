"""Live Link Face timecodes: frame numbers, and the digits after the point when they are
fractions of a frame."""

import pytest

from app.stimuli.capture.timecode import parse_timecode


def test_timecodes():
    assert parse_timecode("14:03:52:28.207", 60) == pytest.approx(14 * 3600 + 3 * 60 + 52 + 28 / 60)
    with pytest.raises(ValueError, match="expected a timecode"):
        parse_timecode("14:03:52", 60)
