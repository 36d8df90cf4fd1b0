"""``facepair capture import``: every format found by its header or extension, one line for
what cannot be imported."""

import numpy as np
import pytest
from click.testing import CliRunner

from app.cli import main
from app.stimuli.io import load_track
from tests.stimuli.capture.files import (
    write_a2f3d_csv,
    write_a2f_json,
    write_bvh,
    write_live_link,
    write_openface,
    write_openfacefx,
)

N = 60


def _files(tmp_path):
    t = np.arange(N) / 30.0
    wave = np.sin(2 * np.pi * t)
    keys = {"jawOpen": [(0.0, 0.0), (1.0, 0.5), (2.0, 0.0)]}
    return {
        "openface": write_openface(tmp_path / "of.csv", t, {"pose_Rx": 0.1 * wave}),
        "arkit": write_live_link(tmp_path / "llf.csv", N, {"HeadPitch": 0.1 * wave}),
        "a2f-csv": write_a2f3d_csv(tmp_path / "animation_frames.csv", t, {"JawOpen": wave**2}),
        "a2f-json": write_a2f_json(tmp_path / "a2f.json", 30.0, {"JawOpen": wave**2}, N),
        "bvh": write_bvh(tmp_path / "genea.bvh", {"Head.Xrotation": 5 * wave}, N),
        "openfacefx-json": write_openfacefx(tmp_path / "t.track.json", 30.0, keys),
        "openfacefx-csv": write_openfacefx(tmp_path / "t.csv", 30.0, keys),
    }


@pytest.mark.parametrize(
    "kind", ["openface", "arkit", "a2f-csv", "a2f-json", "openfacefx-json", "openfacefx-csv", "bvh"]
)
def test_every_format_is_found_and_imported(tmp_path, kind):
    source = _files(tmp_path)[kind]
    out = tmp_path / f"{kind}.fap"
    auto = CliRunner().invoke(main, ["capture", "import", str(source), "--out", str(out)])
    assert auto.exit_code == 0, auto.output
    assert load_track(out).n_frames in (30, 60, 61)
    named = CliRunner().invoke(
        main, ["capture", "import", str(source), "--from", kind, "--out", str(out)]
    )
    assert named.exit_code == 0 and named.output == auto.output


def test_options_that_do_not_apply_and_unknown_files_are_one_line(tmp_path):
    files = _files(tmp_path)
    runner = CliRunner()
    r = runner.invoke(
        main,
        ["capture", "import", str(files["arkit"]), "--out", "x.fap", "--neutral", "median"],
    )
    assert r.exit_code == 2 and "--neutral: --neutral is for OpenFace and BVH files" in r.output
    r = runner.invoke(
        main, ["capture", "import", str(files["bvh"]), "--out", "x.fap", "--flip", "HeadYaw"]
    )
    assert r.exit_code == 2 and "--flip takes ARKit rotation columns" in r.output
    r = runner.invoke(
        main, ["capture", "import", str(files["bvh"]), "--out", "x.fap", "--neutral", "2-1"]
    )
    assert r.exit_code == 2 and "expected median, none or a window START-END" in r.output
    other = tmp_path / "notes.json"
    other.write_text('{"title": "not a track"}')
    r = runner.invoke(main, ["capture", "import", str(other), "--out", "x.fap"])
    assert r.exit_code == 2 and r.output.count("\n") == 1
    assert "notes.json:1: not a file facepair imports (openface, arkit, a2f-csv" in r.output
