"""The generation's summary: notes on imported tracks, plain JSON types."""

import json
from pathlib import Path

import numpy as np

from app.stimuli.summary import capture_note, jsonable


def test_capture_note_carries_the_importers_warnings():
    capture = {
        "samples": 600,
        "capture_fps": 60.0,
        "invalid_samples": 2,
        "filled_frames": 1,
        "missing": {"eyes": [23, 24]},
        "warnings": ["HeadPitch is constant (0): a take recorded without head rotation?"],
    }
    note = capture_note("take.csv", capture)
    assert note.startswith("ground truth imported from take.csv: 600 samples at 60 fps, 2 lost")
    assert "FAPs 23, 24 absent from the file" in note
    assert note.endswith("HeadPitch is constant (0): a take recorded without head rotation?")


def test_the_summary_is_plain_json():
    raw = {1: np.float32(0.5), "n": np.int64(3), "bad": float("nan"), "path": Path("a/b.fap")}
    raw["rows"] = (np.arange(2), [np.inf])
    plain = jsonable(raw)
    assert plain == {"1": 0.5, "n": 3, "bad": None, "path": "a/b.fap", "rows": [[0, 1], [None]]}
    assert json.loads(json.dumps(plain, allow_nan=False)) == plain
