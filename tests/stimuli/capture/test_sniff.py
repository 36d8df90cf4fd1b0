"""Telling the formats apart (``app.stimuli.capture.sniff``) and importing whatever it says."""

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.capture import import_track, sniff, sniff_csv

STARTS = [
    b"frame, face_id, timestamp, confidence, success, pose_Rx\n",
    b"Timecode,BlendShapeCount,JawOpen\n",
    b",timeCode,blendShapes.JawOpen\n",
    b'{"facsNames": ["jawOpen"], "weightMat": ',
    b"HIERARCHY\nROOT Hips\n{",
    b"\xef\xbb\xbf",
    b"",
]


@pytest.mark.parametrize(
    ("start", "name", "kind"),
    [
        (STARTS[0], "a.csv", "openface"),
        (STARTS[1], "a.csv", "arkit"),
        (STARTS[2], "a.csv", "a2f-csv"),
        (STARTS[3], "a.json", "a2f-json"),
        (STARTS[3], "a.txt", "a2f-json"),
        (STARTS[4], "a.txt", "bvh"),
        (b"", "a.bvh", "bvh"),
        (b'{"title": 1}', "a.json", None),
        (b"time, x\n0, 1\n", "a.csv", None),
    ],
)
def test_formats_by_header_keys_or_extension(tmp_path, start, name, kind):
    path = tmp_path / name
    path.write_bytes(start)
    assert sniff(path) == kind
    if name.endswith(".csv"):
        assert sniff_csv(path) == kind


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    start=st.sampled_from(STARTS),
    data=st.binary(max_size=200),
    name=st.sampled_from(["f.csv", "f.json", "f.bvh", "f.txt", "f"]),
)
def test_any_file_is_a_track_or_one_input_error(tmp_path, start, data, name):
    path = tmp_path / name
    path.write_bytes(start + data)
    try:
        import_track(path)
    except InputError as exc:
        assert "\n" not in str(exc) and name in str(exc)
