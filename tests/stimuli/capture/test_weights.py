import json

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cli import main
from app.errors import InputError
from app.stimuli.capture import import_track, sniff, sniff_csv
from app.stimuli.capture.weights import read_a2f_csv, read_a2f_json
from app.stimuli.io import load_track
from tests.stimuli.capture.files import write_a2f3d_csv, write_a2f_json, write_openfacefx

FPS = 30.0


def speech(n=150, fps=FPS):
    """Weights a speech-driven tool writes: a jaw opening and closing at 4 Hz, a blink, a raise."""
    t = np.arange(n) / fps
    return t, {
        "JawOpen": 0.25 + 0.25 * np.sin(2 * np.pi * 4 * t),
        "BrowInnerUp": np.where((t > 1) & (t < 2), 0.4, 0.0),
        "EyeBlinkLeft": np.where((t % 2) > 1.8, 1.0, 0.0),
        "EyeBlinkRight": np.where((t % 2) > 1.8, 1.0, 0.0),
        "MouthFunnel": np.full(n, 0.1),
    }


def test_audio2face_3d_csv_maps_through_the_arkit_table(tmp_path):
    t, v = speech()
    path = write_a2f3d_csv(tmp_path / "animation_frames.csv", t, v)
    header = path.read_text().splitlines()[0]
    assert header.startswith(",timeCode,blendShapes.EyeBlinkLeft,")  # pandas' index first
    assert sniff(path) == sniff_csv(path) == "a2f-csv"
    track = read_a2f_csv(path, FPS)
    assert track.n_frames == 150 and track.fps == FPS
    np.testing.assert_allclose(track[3], 800 * v["JawOpen"], atol=1e-6)
    np.testing.assert_allclose(track[31], 100 * v["BrowInnerUp"], atol=1e-6)
    assert track[19].max() == pytest.approx(0.8 * 1024)
    report = track.metadata["capture"]
    # no rotations in the layout: said, not imported as a still head
    assert report["missing"]["HeadPitch"] == [48] and 48 not in track.channels
    assert load_track(path).channels == track.channels  # a ground truth wherever one is read


def test_audio2face_json_with_camelcase_names_and_its_own_rate(tmp_path):
    t, v = speech(n=120, fps=60.0)
    path = write_a2f_json(tmp_path / "a2f_bs_weights.json", 60.0, v, 120)
    assert sniff(path) == "a2f-json"
    track = read_a2f_json(path, FPS)
    assert track.metadata["capture"]["capture_fps"] == 60 and track.n_frames == 60
    jaw = 800 * (0.25 + 0.25 * np.sin(2 * np.pi * 4 * track.times))
    np.testing.assert_allclose(track[3][2:-2], jaw[2:-2], atol=8)  # resampled 60 -> 30 fps


def test_names_outside_arkit_are_named_and_all_zero_eyes_left_out(tmp_path):
    t, v = speech(n=60)
    v = {k: c for k, c in v.items() if not k.startswith("EyeBlink")}
    names = ["jawOpen", "browInnerUp", "eyeBlinkLeft", "eyeBlinkRight", "tongueUp", "mouthFunnel"]
    path = write_a2f_json(tmp_path / "w.json", 30.0, v, 60, names=names)
    track = read_a2f_json(path, FPS)
    report = track.metadata["capture"]
    assert report["left_out"] == [19, 21, 20, 22] and 19 not in track.channels
    assert report["warnings"][-1] == (
        "1 columns are not ARKit blendshapes and were not imported: 'tongueUp'"
    )
    r = CliRunner().invoke(main, ["capture", "import", str(path), "--out", str(tmp_path / "g.fap")])
    assert r.exit_code == 0, r.output
    assert "FAP 19, 21, 20, 22 left out: their columns are 0 in every frame" in r.output
    assert "no column HeadPitch: FAP 48 not imported" in r.output
    assert "constant in every frame: EyeBlinkLeft = 0, EyeBlinkRight = 0" in r.output


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ([1, 2], "expected a JSON object, got list"),
        (
            {"facsNames": ["jawOpen"], "weightMat": [[0.1], [0.2, 0.3]], "exportFps": 30},
            "weightMat row 1: 2 values for the 1 facsNames",
        ),
        (
            {"facsNames": ["jawOpen"], "weightMat": [[0.1], ["x"]], "exportFps": 30},
            "weightMat row 1: a weight is not a number",
        ),
        (
            {"facsNames": ["jawOpen"], "weightMat": [[0.1], [0.2]], "exportFps": 0},
            "'exportFps' must be a frame rate",
        ),
        (
            {
                "facsNames": ["jawOpen"],
                "weightMat": [[0.1], [0.2]],
                "exportFps": 30,
                "numFrames": 3,
            },
            "numFrames says 3, weightMat has 2 rows",
        ),
    ],
)
def test_bad_json_is_one_line_naming_the_file(tmp_path, doc, message):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=f"bad.json: not an Audio2Face weights JSON: {message}"):
        read_a2f_json(path)
    path.write_text('{"facsNames": ["jawOpen"],\n "weightMat": [[0.1], [0.2]\n')
    with pytest.raises(InputError, match=r"bad.json:3: not JSON: "):
        read_a2f_json(path)


def test_bad_csv_rows_are_named(tmp_path):
    t, v = speech(n=30)
    path = write_a2f3d_csv(tmp_path / "a.csv", t, v)
    lines = path.read_text().splitlines()
    lines[4] = lines[4].replace(",", ",x", 1)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"a.csv:5: column timeCode: not a number: 'x"):
        read_a2f_csv(path)


_HEADER = ",timeCode,blendShapes.JawOpen,blendShapes.EyeBlinkLeft,blendShapes.BrowInnerUp\n"


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(st.text(alphabet="0123456789.,-+e naixf\n", max_size=40), max_size=12))
def test_junk_csv_rows_are_one_input_error_never_a_crash(tmp_path, rows):
    path = tmp_path / "junk.csv"
    path.write_text(_HEADER + "\n".join(rows))
    try:
        import_track(path)
    except InputError as exc:
        assert "\n" not in str(exc) and "junk.csv" in str(exc)


_json = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=True) | st.integers() | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=20,
)


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    names=st.lists(st.sampled_from(["jawOpen", "JawOpen", "eyeBlinkLeft", "x", ""]), max_size=4),
    rows=st.lists(
        st.lists(st.floats() | st.integers() | st.text(max_size=3), max_size=4), max_size=6
    ),
    fps=_json,
    extra=st.dictionaries(
        st.sampled_from(["numFrames", "facsNames", "weightMat", "z"]), _json, max_size=2
    ),
)
def test_any_json_is_a_track_or_one_input_error(tmp_path, names, rows, fps, extra):
    path = tmp_path / "any.json"
    doc = {"exportFps": fps, "facsNames": names, "weightMat": rows, **extra}
    path.write_text(json.dumps(doc))
    try:
        read_a2f_json(path)
    except InputError as exc:
        assert "\n" not in str(exc) and "any.json" in str(exc)


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.binary(max_size=300))
def test_any_bytes_are_a_track_or_one_input_error(tmp_path, data):
    for name in ("b.json", "b.csv"):
        path = tmp_path / name
        path.write_bytes(
            b'{"facsNames": ' + data if name.endswith("json") else _HEADER.encode() + data
        )
        try:
            import_track(path, "a2f-json" if name.endswith("json") else "a2f-csv")
        except InputError as exc:
            assert "\n" not in str(exc) and name in str(exc)


@pytest.mark.parametrize("name", ["take.track.json", "take.csv"])
def test_openfacefx_keys_are_the_straight_line_between_them(tmp_path, name):
    keys = {
        "jawOpen": [(0.0, 0.0), (0.5, 0.5), (1.0, 0.1), (2.0, 0.1)],
        "browInnerUp": [(0.0, 0.0), (1.2, 0.4), (2.0, 0.4)],
        "PP": [(0.0, 0.0), (1.0, 1.0)],  # an Oculus viseme left in the track
    }
    path = write_openfacefx(tmp_path / name, 30.0, keys)
    kind = "openfacefx-json" if name.endswith("json") else "openfacefx-csv"
    assert sniff(path) == kind
    track = import_track(path, fps=30.0)
    assert track.n_frames == 61
    t = track.times
    jaw = np.interp(t, [0, 0.5, 1, 2], [0, 0.5, 0.1, 0.1])
    np.testing.assert_allclose(track[3], 800 * jaw, atol=1e-9)
    np.testing.assert_allclose(track[31], 100 * np.interp(t, [0, 1.2, 2], [0, 0.4, 0.4]))
    assert track.metadata["capture"]["warnings"][-1] == (
        "1 columns are not ARKit blendshapes and were not imported: 'PP'"
    )


def test_an_openfacefx_track_of_visemes_says_how_to_retarget(tmp_path):
    path = write_openfacefx(tmp_path / "v.json", 30.0, {"PP": [(0.0, 0.0), (1.0, 1.0)]})
    with pytest.raises(
        InputError, match=r"v.json: no ARKit channel among 1 \(PP\).*--retarget arkit"
    ):
        import_track(path)


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    channels=st.lists(
        st.fixed_dictionaries(
            {
                "name": st.sampled_from(["jawOpen", "PP", "eyeBlinkLeft", ""]) | _json,
                "keys": st.lists(
                    st.lists(st.floats() | st.integers() | st.just(10**400), max_size=3), max_size=4
                )
                | _json,
            }
        ),
        max_size=3,
    ),
    fps=_json,
)
def test_any_openfacefx_json_is_a_track_or_one_input_error(tmp_path, channels, fps):
    path = tmp_path / "any.json"
    path.write_text(json.dumps({"format": "openfacefx.track", "fps": fps, "channels": channels}))
    try:
        import_track(path)
    except InputError as exc:
        assert "\n" not in str(exc) and "any.json" in str(exc)


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(st.text(alphabet="0123456789.,-e jawOpnPPx\n", max_size=30), max_size=10))
def test_junk_openfacefx_csv_rows_are_one_input_error(tmp_path, rows):
    path = tmp_path / "keys.csv"
    path.write_text("time,channel,value\n" + "\n".join(rows))
    try:
        import_track(path)
    except InputError as exc:
        assert "\n" not in str(exc) and "keys.csv" in str(exc)
