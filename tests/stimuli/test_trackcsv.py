import io

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.io import load_track, save_track
from app.stimuli.track import MotionTrack
from app.stimuli.trackcsv import read_track_csv, write_track_csv


def test_round_trip_is_exact_for_arbitrary_floats(tmp_path):
    rng = np.random.default_rng(2)
    track = MotionTrack(
        29.97, rng.normal(0, 1e4, (40, 3)) / 7, (23, 25, 49), name="n", speaker="sp; one"
    )
    write_track_csv(track, tmp_path / "t.csv")
    back = read_track_csv(tmp_path / "t.csv")
    assert back.equals(track) and back.name == "n"


def test_csv_and_fap_convert_both_ways(tmp_path):
    track = MotionTrack(30, np.rint(np.arange(20.0).reshape(10, 2) * 37), (31, 48))
    save_track(track, tmp_path / "a.fap")
    save_track(load_track(tmp_path / "a.fap"), tmp_path / "a.csv")
    assert load_track(tmp_path / "a.csv").equals(track)


def test_fps_must_come_from_somewhere():
    text = "frame,fap48_head_pitch\n0,1\n1,2\n"
    with pytest.raises(InputError, match="give the frame rate"):
        read_track_csv(io.StringIO(text))
    assert read_track_csv(io.StringIO(text), fps=25).fps == 25


@pytest.mark.parametrize(
    "text,expected",
    [
        ("# fps=30\nframe,head\n0,1\n", ":2: not a FAP column"),
        ("# fps=30\ntime,fap48\n0,1\n", ":2: first column is 'time'"),
        ("# fps=30\nframe,fap48\n0,abc\n", ":3: fap48 is 'abc', expected a number"),
        ("# fps=30\nframe,fap48\n0,1,2\n", ":3: expected 2 columns, got 3"),
        ("# fps=30\nframe,fap48\n0,nan\n", ":3: fap48 is 'nan', expected a finite number"),
        ("# fps=30\nframe,fap48\n1,1\n0,1\n", "must start at >= 0 and increase"),
        ("# fps=-1\nframe,fap48\n0,1\n", "expected a number > 0"),
    ],
)
def test_bad_csv_names_line_and_field(tmp_path, text, expected):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        read_track_csv(path)
    assert expected in str(err.value) and str(err.value).startswith(str(path))


def test_unknown_extension(tmp_path):
    with pytest.raises(InputError, match="expected .fap, .csv, .json or .bvh"):
        load_track(tmp_path / "x.xyz")
