"""``facepair render pair/still`` with mesh and FLAME tracks beside the built-in head.

The fixtures are made here: a FaceFormer-layout VOCASET sequence (5,023 vertices, (T, 3V), metres,
30 fps), a BIWI-layout one (23,370 vertices, BIWI's 0.2 m units, 25 fps), a DiffPoseTalk-layout
FLAME parameter file with a model of FLAME's structure the test builds (never FLAME).
"""

import imageio.v3 as iio
import numpy as np
import pytest
from click.testing import CliRunner

from app.cli import main
from app.stimuli.io import save_track
from app.stimuli.meshes.regions import speech_energy
from app.stimuli.track import MotionTrack
from tests.stimuli.meshes.synthetic import (
    flame_like_model,
    head_mesh,
    opening_from_energy,
    talking,
    write_flame_pkl,
    write_layout,
)

DEMO = "app/data/demo/speech.wav"  # 4 s of speech


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("meshes")
    vocaset = head_mesh(n_vertices=5023)
    at30 = opening_from_energy(speech_energy(DEMO, 30.0, 120))
    ff = write_layout(folder / "vocaset", "test", vocaset, talking(vocaset, at30), flat=True)
    biwi = head_mesh(40, 48, eyes=False, n_vertices=23370)
    at25 = opening_from_energy(speech_energy(DEMO, 25.0, 100))
    bw = write_layout(folder / "biwi", "test", biwi, talking(biwi, at25), flat=True, scale=0.2)
    model = write_flame_pkl(folder / "generic_model.pkl", flame_like_model(vocaset))
    pose = np.zeros((100, 6))
    pose[:, 3] = at25
    pose[:, 1] = 0.1 * np.sin(np.arange(100) / 10)  # the head's own turn
    np.savez(folder / "dpt.npz", exp=np.zeros((100, 50)), pose=pose, shape=np.zeros(100))
    built_in = folder / "builtin.fap"
    save_track(
        MotionTrack.from_channels(30.0, {3: 300 * at30 / at30.max(), 19: np.ones(120)}), built_in
    )
    return {"ff": ff, "biwi": bw, "model": model, "dpt": folder / "dpt.npz", "builtin": built_in}


def _run(*args, env=None):
    return CliRunner().invoke(main, [str(a) for a in args], env=env)


@pytest.mark.gl
@pytest.mark.parametrize(
    ("track", "options"),
    [
        ("ff", ["--mesh-fps", 30]),
        ("biwi", ["--mesh-fps", 25]),
        ("dpt", ["--mesh-fps", 25, "--flame-model", "{model}"]),
    ],
)
def test_each_layout_renders_in_a_pair_beside_the_built_in_head(tmp_path, files, track, options):
    options = [str(o).format(**files) for o in options]
    out = tmp_path / "pair.mp4"
    res = _run(
        "render", "pair", "--left", files[track], "--right", files["builtin"], "--audio", DEMO,
        "--out", out, "--size", 96, "--mosaic-block", 12, "--workers", 1, *options,
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert out.stat().st_size > 2000 and "192x96, 120 frames" in res.output
    assert "mesh_eyes = 'match'" in res.output  # the built-in head's blinks are off
    still = tmp_path / "still.png"
    res = _run(
        "render", "still", "--track", files[track], "--right", files["builtin"], "--frame", 30,
        "--out", still, "--size", 96, "--mosaic-block", 12, *options,
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    image = iio.imread(still)
    assert image.shape == (96, 192, 3)
    background = np.array([image[0, 0], image[0, -1]])
    for side in (image[:, :96], image[:, 96:]):
        assert (np.abs(side.astype(int) - background[0]).sum(axis=2) > 30).mean() > 0.1


def test_bad_mesh_input_is_one_line_naming_the_file(tmp_path, files, monkeypatch):
    monkeypatch.delenv("FACEPAIR_FLAME_MODEL", raising=False)
    still = ["render", "still", "--out", tmp_path / "x.png", "--size", 64, "--track"]
    res = _run(*still, files["ff"])
    assert res.exit_code == 2
    assert res.output.strip().startswith("facepair: error: test.npy: give the sequence's frame")
    res = _run(*still, files["dpt"], "--mesh-fps", 25)
    assert res.exit_code == 2 and "dpt.npz: a FLAME parameter sequence needs your own" in res.output
    bad = tmp_path / "bad.npy"
    frames = np.load(files["ff"])
    frames[3, 5] = np.nan
    np.save(bad, frames)
    (tmp_path / "bad.obj").write_bytes(files["ff"].with_suffix(".obj").read_bytes())
    res = _run(*still, bad, "--mesh-fps", 30)
    assert res.exit_code == 2 and "bad.npy: 1 frame(s) hold NaN" in res.output
    res = _run(*still, files["ff"], "--mesh-fps", 30, "--units", "mm")
    assert res.exit_code == 2 and "units implausible" in res.output
    for line in (r.output for r in [res]):
        assert line.count("\n") == 1 and "Traceback" not in line


def test_a_sequence_off_its_audio_is_refused_unless_padded(tmp_path, files):
    out = tmp_path / "p.mp4"
    pair = ["render", "pair", "--right", files["builtin"], "--audio", DEMO, "--out", out]
    res = _run(*pair, "--left", files["ff"], "--mesh-fps", 25)  # 120 frames read at 25: 4.8 s
    assert res.exit_code == 2
    assert "test.npy: track: 4.80 s of motion for 4.00 s of speech: 0.80 s too long" in res.output
