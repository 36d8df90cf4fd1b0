import json

from click.testing import CliRunner

from app.cli import main
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
