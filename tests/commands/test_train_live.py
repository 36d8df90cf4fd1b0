"""``facepair stimuli train-live``: trains, writes a loadable model, bad input is one line."""

from __future__ import annotations

from click.testing import CliRunner

from app.cli import main
from app.stimuli.live.modelfile import load_model


def test_train_live_on_the_demo_ground_truth(repo_root, tmp_path):
    out = tmp_path / "model.npz"
    result = CliRunner().invoke(
        main,
        [
            "stimuli",
            "train-live",
            "--audio",
            str(repo_root / "app/data/demo/speech.wav"),
            "--ground-truth",
            str(repo_root / "app/data/demo/ground_truth.fap"),
            "--pitch-ceiling",
            "300",
            "--components",
            "3",
            "--out",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    model = load_model(out)
    assert model.summary["frames"] == 120 and model.summary["takes"] == 1
    assert 48 in model.summary["channels"] and model.summary["gaze_enabled"]


def test_train_live_on_the_repeated_reference_speaker(repo_root, tmp_path):
    out = tmp_path / "model.npz"
    result = CliRunner().invoke(
        main,
        [
            "stimuli",
            "train-live",
            "--audio",
            str(repo_root / "app/data/demo/speech.wav"),
            "--reference",
            "--repeat",
            "5",
            "--components",
            "2",
            "--out",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    assert load_model(out).summary["frames"] == 600


def test_bad_input_is_one_line_exit_2(repo_root, tmp_path):
    runner = CliRunner()
    wav = str(repo_root / "app/data/demo/speech.wav")
    result = runner.invoke(
        main, ["stimuli", "train-live", "--audio", wav, "--out", str(tmp_path / "m.npz")]
    )
    assert result.exit_code == 2 and "--ground-truth" in result.output
    assert len(result.output.strip().splitlines()) == 1
    bad = tmp_path / "gt.fap"
    bad.write_text("not a fap file\n")
    result = runner.invoke(
        main,
        [
            "stimuli",
            "train-live",
            "--audio",
            wav,
            "--ground-truth",
            str(bad),
            "--out",
            str(tmp_path / "m.npz"),
        ],
    )
    assert result.exit_code == 2 and str(bad) in result.output
    assert len(result.output.strip().splitlines()) == 1
