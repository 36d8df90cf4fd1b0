"""A track as long as its speech (app.stimuli.lengths): silent within a frame, a note within
the tolerance, one line naming the file beyond it unless padding is allowed."""

from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.lengths import LENGTH_TOLERANCE_S, length_note
from app.stimuli.track import MotionTrack


def test_within_a_frame_is_silent_and_the_tolerance_is_documented_value():
    assert LENGTH_TOLERANCE_S == 0.2
    assert length_note(MotionTrack.zeros(30, 119, (48,)), 120, 30.0, what="x") is None


def test_an_offset_counts_towards_the_end():
    track = MotionTrack.zeros(30, 90, (48,))  # 3 s starting 1 s late: ends with the speech
    assert length_note(track, 120, 30.0, what="ground truth", offset=1.0) is None
    note = length_note(track, 120, 30.0, what="gt", offset=1.1)
    assert (
        note
        == "gt: 3.00 s of motion for 4.00 s of speech (starting +1.10 s): its last 0.10 s are cut"
    )


@settings(max_examples=200, deadline=None)
@given(
    frames=st.integers(0, 3000),
    speech=st.integers(1, 3000),
    fps=st.sampled_from([24.0, 25.0, 30.0, 60.0]),
    offset=st.floats(-5, 5, allow_nan=False),
    pad=st.booleans(),
)
def test_any_length_is_silent_a_note_or_one_line_naming_the_file(frames, speech, fps, offset, pad):
    track = MotionTrack.zeros(fps, frames, (48,))
    gap = speech / fps - (offset + frames / fps)
    try:
        note = length_note(
            track, speech, fps, what="condition c", path="c.csv", offset=offset, pad=pad
        )
    except InputError as exc:
        line = str(exc)
        assert not pad and abs(gap) > LENGTH_TOLERANCE_S
        assert line.startswith("c.csv: condition c: ") and "\n" not in line
        return
    if abs(gap) <= 1 / fps + 1e-9:
        assert note is None
    else:
        assert note is not None and note.startswith("condition c: ")
        assert pad or abs(gap) <= LENGTH_TOLERANCE_S + 1e-9
        assert ("hold its last frame" in note) == (gap > 0)
