import json

import numpy as np
import pytest
from click.testing import CliRunner

from app.cli import main
from app.stimuli.fapfile import read_fap
from app.stimuli.generate import generate_conditions


def test_demo_generates_four_conditions(repo_root, tmp_path):
    demo = repo_root / "data" / "demo"
    result = generate_conditions(demo / "speech.wav", ground_truth=demo / "ground_truth.fap",
                                 normalize=True, seed=1, pitch_ceiling=300)
    assert set(result.tracks) == {"none", "random", "speech_driven", "ground_truth"}
    assert all(t.n_frames == 120 for t in result.tracks.values())
    assert result.summary["ground_truth"]["synthetic"] is True
    json.dumps(result.summary)


def test_cli_writes_tracks_summary_and_plot(repo_root, tmp_path):
    demo = repo_root / "data" / "demo"
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["stimuli", "generate", "--audio", str(demo / "speech.wav"),
                                  "--out", str(out), "--no-plot"])
    assert r.exit_code == 0, r.output
    assert {p.name for p in out.iterdir()} == {"none.fap", "random.fap", "speech_driven.fap",
                                               "summary.json"}
    summary = json.loads((out / "summary.json").read_text())
    assert "default head model" in summary["conditions"]["speech_driven"]["head_model"]
    bad = CliRunner().invoke(main, ["stimuli", "generate", "--audio", str(demo / "speech.wav"),
                                    "--out", str(out), "--normalize"])
    assert bad.exit_code == 2 and "needs a reference" in bad.output


def _greta_ground_truth(path, n_frames=120, fps=30, seed=3):
    """Write a .fap as Greta writes it; return {FAP: values} of the low-level FAPs in it.

    69-value masks: FAP i at position i, then one extra entry; one integer per masked
    position, the viseme (position 1) and the extra (position 69) included.
    """
    positions = (1, 3, 4, 19, 48, 49, 50, 51, 68, 69)
    rng = np.random.default_rng(seed)
    values = rng.integers(-3000, 3000, (n_frames, len(positions)))
    bits = ["1" if p in positions else "0" for p in range(1, 70)]
    lines = [f"2.1 {path.name} {fps} {n_frames}"]
    for i in range(n_frames):
        lines += [" ".join(bits) + " ", " ".join(map(str, [i, *values[i]])) + " "]
    path.write_text("\n".join(lines) + "\n")
    return {p: values[:, k] for k, p in enumerate(positions) if 3 <= p <= 68}


@pytest.mark.parametrize("greta", [False, True])
def test_greta_ground_truth_passes_through_unchanged(repo_root, tmp_path, greta):
    gt_path = tmp_path / "greta_gt.fap"
    expected = _greta_ground_truth(gt_path)
    out = tmp_path / "out"
    args = ["stimuli", "generate", "--audio", str(repo_root / "data" / "demo" / "speech.wav"),
            "--ground-truth", str(gt_path), "--conditions", "ground_truth", "--out", str(out),
            "--no-plot"] + (["--greta"] if greta else [])
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    written = out / "ground_truth.fap"
    track = read_fap(written)
    assert track.n_frames == 120 and track.fps == 30
    assert track.channels == tuple(expected)
    for fap, values in expected.items():
        np.testing.assert_array_equal(track[fap], values)
    body = [line.split() for line in written.read_text().splitlines()
            if not line.startswith("#")][1:]
    # the same positions masked, less the viseme and Greta's extra entry; 69 values with --greta
    bits = ["1" if p in expected else "0" for p in range(1, 70 if greta else 69)]
    assert body[::2] == [bits] * 120
