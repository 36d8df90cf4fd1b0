"""The .fap dialects (``app.stimuli.fapdialects``): each dialect's layout of a mask, the dialect a
mask line says, the one line for a value line of the wrong length, and the writer's lines."""

import io

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.fapdialects import (
    EARLY_FACEPAIR_GRETA,
    GRETA,
    GRETA_WRITER_LINE,
    WRITER_LINE,
    XFACE,
    count_error,
    dialect_of,
    mask_layout,
)
from app.stimuli.fapfile import read_fap, write_fap
from app.stimuli.track import MotionTrack

DIALECTS = {"xface": XFACE, "greta": GRETA, "early": EARLY_FACEPAIR_GRETA}


def bits(positions, n):
    """A mask of ``n`` values with 1 at the given positions (counted from 1)."""
    out = [0] * n
    for p in positions:
        out[p - 1] = 1
    return tuple(out)


def mask_line(positions, n):
    return " ".join(map(str, bits(positions, n)))


def body(text):
    """The lines of a .fap file other than comments."""
    return [line for line in text.splitlines() if line.strip() and not line.startswith("#")]


# -- the table -----------------------------------------------------------------------------------


def test_position_i_is_fap_i_except_in_early_facepair_files():
    assert len(XFACE.faps) == 68 and len(GRETA.faps) == 69 and len(EARLY_FACEPAIR_GRETA.faps) == 69
    # position 48 (index 47) is head_pitch, FAP 48, in both players' dialects
    assert XFACE.faps[47] == GRETA.faps[47] == 48
    assert GRETA.faps[68] == 0  # Greta's extra entry after FAP 68 is no FAP
    # early facepair files: a null FAP 0 first, FAP 48 at position 49, FAP 68 at position 69
    assert EARLY_FACEPAIR_GRETA.faps[0] == 0
    assert EARLY_FACEPAIR_GRETA.faps[48] == 48 and EARLY_FACEPAIR_GRETA.faps[68] == 68


@pytest.mark.parametrize(
    ("dialect", "widths"),
    [
        (XFACE, (4, 6, 1, 1)),
        (GRETA, (1, 1, 1, 1)),
        (EARLY_FACEPAIR_GRETA, (4, 6, 1, 1)),
    ],
)
def test_values_per_fap(dialect, widths):
    # FAP 1 viseme, FAP 2 expression, FAP 3 open_jaw, none (0)
    assert tuple(dialect.width(fap) for fap in (1, 2, 3, 0)) == widths


def test_the_writer_lines_are_the_files_first_comments():
    # files on disk carry these lines: the first marks the early Greta-style files
    assert WRITER_LINE == "MPEG-4 FAP stream written by facepair"
    assert GRETA_WRITER_LINE == (
        "MPEG-4 FAP stream written by facepair in Greta's layout: FAP 1..68, then one extra entry"
    )
    track = MotionTrack(25, np.array([[1.0]]), (48,))
    xface, greta = io.StringIO(), io.StringIO()
    write_fap(track, xface)
    write_fap(track, greta, greta=True)
    assert xface.getvalue().splitlines()[0] == "# MPEG-4 FAP stream written by facepair"
    assert greta.getvalue().splitlines()[0] == (
        "# MPEG-4 FAP stream written by facepair in Greta's layout: FAP 1..68, then one extra entry"
    )


# -- mask_layout ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("dialect", "mask", "columns", "places", "width", "high"),
    [
        # FAP 1 at place 1 (4 values), FAP 2 at 5 (6 values), FAP 3 at 11, FAP 48 at 12
        (XFACE, bits([1, 2, 3, 48], 68), [2, 47], [11, 12], 12, ((1, 1, 4), (2, 5, 6))),
        # one value each: FAP 1, 2, 3, 48 at places 1-4, then the extra entry at 5
        (GRETA, bits([1, 2, 3, 48, 69], 69), [2, 47], [3, 4], 5, ((1, 1, 1), (2, 2, 1))),
        # null FAP 0 at place 1, FAP 1 at 2 (4), FAP 2 at 6 (6), FAP 47 at 12, FAP 68 at 13
        (
            EARLY_FACEPAIR_GRETA,
            bits([1, 2, 3, 48, 69], 69),
            [46, 67],
            [12, 13],
            13,
            ((1, 2, 4), (2, 6, 6)),
        ),
        (XFACE, bits([], 68), [], [], 0, ()),
        (GRETA, bits([69], 69), [], [], 1, ()),
    ],
    ids=["xface", "greta", "early", "xface-empty", "greta-extra-only"],
)
def test_layout_of_a_known_mask(dialect, mask, columns, places, width, high):
    got_columns, got_places, got_width, got_high = mask_layout(dialect, mask)
    assert got_columns.tolist() == columns and got_places.tolist() == places
    assert got_width == width and got_high == high


@settings(max_examples=200, deadline=None)
@given(st.sampled_from(sorted(DIALECTS)), st.data())
def test_layout_spans_tile_the_value_line(name, data):
    """Every masked position takes its own run of places, and the runs fill 1..width."""
    dialect = DIALECTS[name]
    mask = tuple(data.draw(st.lists(st.sampled_from([0, 1]), min_size=69, max_size=69)))[
        : len(dialect.faps)
    ]
    columns, places, width, high = mask_layout(dialect, mask)
    masked = [fap for fap, bit in zip(dialect.faps, mask, strict=True) if bit]
    assert columns.tolist() == [fap - 1 for fap in masked if fap >= 3]
    assert [fap for fap, _, _ in high] == [fap for fap in masked if fap in (1, 2)]
    spans = [(int(p), 1) for p in places] + [(place, n) for _, place, n in high]
    taken = sorted(p for start, n in spans for p in range(start, start + n))
    assert len(taken) == len(set(taken)) and all(1 <= p <= width for p in taken)
    null_entries = masked.count(0)  # Greta's extra entry, the early files' FAP 0: one place each
    assert width == len(taken) + null_entries


# -- dialect_of ----------------------------------------------------------------------------------

# mask lines of real files (docs/reference/stimuli.md, tests/stimuli/test_fapfile.py)
GRETA_LIPS_MASK = (
    "0 0 1 1 1 1 1 1 1 1 1 1 1 0 0 1 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 "
    "1 1 0 0 0 0 0 0 0 0 1 1 1 1 1 1 1 1 1 1 1 1 1 0 0 0 0 0 0"
)
EARLY_MASK = (
    "0 0 0 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 "
    "0 0 0 0 0 0 0 0 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 1"
)


@pytest.mark.parametrize(
    ("first_comment", "mask", "dialect"),
    [
        (None, mask_line([48, 49], 68), XFACE),
        ("MPEG-4 FAP stream written by facepair", mask_line([48, 49], 68), XFACE),
        (None, GRETA_LIPS_MASK, GRETA),
        ("recorded in the lab", GRETA_LIPS_MASK, GRETA),
        (GRETA_WRITER_LINE, EARLY_MASK, GRETA),
        ("MPEG-4 FAP stream written by facepair", EARLY_MASK, EARLY_FACEPAIR_GRETA),
    ],
)
def test_the_mask_length_and_first_comment_say_the_dialect(first_comment, mask, dialect):
    early = first_comment == WRITER_LINE
    assert dialect_of([int(b) for b in mask.split()], early, "a.fap", 2) is dialect


@pytest.mark.parametrize("length", [0, 3, 67, 70])
def test_any_other_mask_length_is_one_line_naming_the_line(length):
    with pytest.raises(InputError) as caught:
        dialect_of([0] * length, False, "a.fap", 5)
    assert str(caught.value) == (
        f"a.fap:5: mask line: expected 68 (Xface) or 69 (Greta) values of 0/1, got {length}"
    )
    assert caught.value.line == 5


# -- count_error ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("dialect", "mask", "got", "message"),
    [
        (
            XFACE,
            bits([1, 48], 68),
            3,
            "gt.fap:3: value line: expected the frame index and 5 values for the 2 masked "
            "positions (68-value mask: Xface/MPEG-4, 4 values for FAP 1, 6 for FAP 2; Greta, one "
            "value each, would expect 2), got 3 numbers",
        ),
        (
            GRETA,
            bits([1, 2, 48], 69),
            13,
            "gt.fap:3: value line: expected the frame index and 3 values for the 3 masked "
            "positions (69-value mask: Greta, one value per masked position; Xface/MPEG-4, 4 for "
            "FAP 1 and 6 for FAP 2, would expect 11), got 13 numbers",
        ),
        (
            EARLY_FACEPAIR_GRETA,
            bits([1, 2, 49], 69),
            2,
            "gt.fap:3: value line: expected the frame index and 6 values for the 3 masked "
            "positions (69-value mask of an early facepair file: null FAP 0, then FAP 1..68, "
            "MPEG-4 widths; Greta, one value each, would expect 3), got 2 numbers",
        ),
    ],
    ids=["xface", "greta", "early"],
)
def test_count_error_names_the_line_and_both_dialects_counts(dialect, mask, got, message):
    error = count_error(dialect, mask, got, "gt.fap", 3)
    assert isinstance(error, InputError)
    assert str(error) == message
    assert (error.path, error.line) == ("gt.fap", 3)


# -- writing then reading ------------------------------------------------------------------------


@pytest.mark.parametrize("greta", [False, True], ids=["xface", "greta"])
def test_writing_then_reading_round_trips_in_each_dialect(greta):
    track = MotionTrack(
        25, np.array([[120.0, -300.0, 7.0], [140.0, -250.0, 9.0]]), (3, 48, 68), source="lab"
    )
    out = io.StringIO()
    write_fap(track, out, greta=greta)
    n = 69 if greta else 68
    assert body(out.getvalue()) == [
        "2.1 facepair 25 2",
        mask_line([3, 48, 68], n),
        "0 120 -300 7",
        mask_line([3, 48, 68], n),
        "1 140 -250 9",
    ]
    back = read_fap(io.StringIO(out.getvalue()))
    assert back.equals(track) and back.source == "lab"


@pytest.mark.parametrize(
    ("n", "greta", "first_value_line"),
    [
        # FAP 1: select1 select2 blend def; FAP 2: select1 intensity1 select2 intensity2
        # init_face def; then FAP 48
        (68, False, "0 3 7 60 1 2 80 5 20 0 1 -250"),
        # one value each for FAP 1 and FAP 2
        (69, True, "0 3 2 -250"),
    ],
    ids=["xface", "greta"],
)
def test_high_level_values_round_trip_in_their_own_dialect(n, greta, first_value_line):
    text = "\n".join(
        [
            "2.1 hl 25 2",
            mask_line([1, 2, 48], n),
            first_value_line,
            mask_line([48], n),
            "1 -300",
        ]
    )
    track = read_fap(io.StringIO(text + "\n"))
    assert track.channels == (48,) and track[48].tolist() == [-250.0, -300.0]
    out = io.StringIO()
    assert write_fap(track, out, greta=greta) is None
    assert body(out.getvalue()) == text.splitlines()


def test_greta_high_level_values_are_left_out_of_xface_with_the_widths_named():
    text = f"2.1 hl 25 1\n{mask_line([1, 2, 48], 69)}\n0 3 2 -250\n"
    out = io.StringIO()
    left_out = write_fap(read_fap(io.StringIO(text)), out)
    assert left_out == (
        "FAP 1 (viseme) and FAP 2 (expression) not written: they came with 1, 1 value(s) a "
        "frame, the 68-value mask: Xface/MPEG-4, 4 values for FAP 1, 6 for FAP 2 takes 4, 6"
    )
    assert body(out.getvalue())[1:] == [mask_line([48], 68), "0 -250"]


def test_early_facepair_files_read_shifted_and_write_back_in_either_dialect():
    early = f"# MPEG-4 FAP stream written by facepair\n2.1 old 25 1\n{EARLY_MASK}\n0 120 -300 7\n"
    track = read_fap(io.StringIO(early))
    # positions 4, 49 and 69 hold FAP 3, 48 and 68
    assert track.channels == (3, 48, 68) and track.values.tolist() == [[120, -300, 7]]
    # without the writer line the same mask is Greta's: FAP 4 and 49, then the extra entry
    greta = read_fap(io.StringIO(early.split("\n", 1)[1]))
    assert greta.channels == (4, 49) and greta.values.tolist() == [[120, -300]]
    for as_greta in (False, True):
        out = io.StringIO()
        write_fap(track, out, greta=as_greta)
        assert read_fap(io.StringIO(out.getvalue())).equals(track)
