import json

import numpy as np
import pytest
from click.testing import CliRunner

from app.cli import main
from app.errors import InputError
from app.stimuli.evaluate import coupling, evaluate_conditions, power_above, split_take
from app.stimuli.io import save_track
from app.stimuli.reference_speaker import synthesize_reference
from app.stimuli.speech import SpeechFeatures, extract_features
from app.stimuli.track import MotionTrack
from tests.stimuli.conftest import harmonic_glide, live_synthetic_speaker, write_wav


def test_power_above_4_hz_of_known_sines():
    t = np.arange(900) / 30.0
    assert power_above(np.sin(2 * np.pi * 1.0 * t), 30.0) < 1e-3
    assert power_above(np.sin(2 * np.pi * 6.0 * t), 30.0) > 0.999
    mixed = np.sin(2 * np.pi * 1.0 * t) + np.sin(2 * np.pi * 6.0 * t)  # equal power
    assert abs(power_above(mixed, 30.0) - 0.5) < 0.02
    assert power_above(np.zeros(900), 30.0) is None


def test_coupling_of_a_linear_function_of_speech_is_one():
    rng = np.random.default_rng(0)
    f0, inten = 120 + 20 * rng.standard_normal(300), 60 + 5 * rng.standard_normal(300)
    feats = SpeechFeatures(30.0, f0, inten, f0)
    track = MotionTrack.from_channels(30.0, {48: 2 * f0 + 3 * inten, 49: rng.standard_normal(300)})
    assert coupling(track, feats)["head"] == pytest.approx(1.0)
    assert coupling(track, feats)["eyebrows"] is None


@pytest.fixture(scope="module")
def report():
    """Trained on one synthetic speaker take, measured on another with other speech."""
    train = [live_synthetic_speaker(1800, 30.0, seed=1)]
    test = [live_synthetic_speaker(1800, 30.0, seed=7)]
    return evaluate_conditions(train, test, seed=0, n_random_seeds=5, n_shifts=10)


def test_ground_truth_is_perfect_and_its_time_shift_is_chance(report):
    gt = report["conditions"]["ground_truth"]["channels"]["49"]
    assert gt["r_truth"]["mean"] == pytest.approx(1.0)
    shifted = report["baselines"]["ground_truth_shifted"]
    assert shifted["channels"]["49"]["r_truth"]["n"] == 10
    assert abs(shifted["channels"]["49"]["r_truth"]["mean"]) < 0.3
    # a shifted truth keeps its own kinematics: same sd, same jitter
    assert shifted["channels"]["49"]["sd"]["mean"] == pytest.approx(gt["sd"]["mean"])


def test_a_model_of_this_speech_beats_both_null_baselines(report):
    sd = report["conditions"]["speech_driven"]
    random = report["baselines"]["random_5_seeds"]
    head, base = sd["coupling"]["head"]["mean"], random["coupling"]["head"]
    assert head > base["mean"] + 3 * base["sd"]
    shifted = report["baselines"]["ground_truth_shifted"]["channels"]["49"]["r_truth"]
    assert sd["channels"]["49"]["r_truth"]["mean"] > shifted["mean"] + 3 * shifted["sd"]
    none = report["conditions"]["none"]
    assert none["coupling"]["head"]["mean"] is None and none["channels"]["49"]["sd"]["mean"] == 0
    assert report["train"]["frames"] == report["test"]["frames"] == 1800


def test_splits_are_explicit_and_disjoint():
    feats, truth = live_synthetic_speaker(600, 30.0, seed=2)
    (tr_f, tr_t), (te_f, te_t) = split_take((feats, truth), 0.5)
    assert tr_f.n_frames == te_f.n_frames == 300
    np.testing.assert_array_equal(np.r_[tr_f.f0, te_f.f0], feats.f0)
    np.testing.assert_array_equal(np.vstack([tr_t.values, te_t.values]), truth.values)
    with pytest.raises(InputError, match="at least 3 s"):
        split_take((feats.slice(0, 150), truth.fit_length(150)), 0.5)
    with pytest.raises(InputError, match="between 0.1 and 0.9"):
        split_take((feats, truth), 1.0)
    with pytest.raises(InputError, match="at least one training"):
        evaluate_conditions([], [(feats, truth)])


def test_cli_writes_the_evaluation_and_extends_a_summary(tmp_path):
    x, _ = harmonic_glide(110.0, 170.0, 8.0)
    pause = np.zeros(4000)
    audio = tmp_path / "voice.wav"
    write_wav(audio, np.r_[pause, x[:40000], pause, x[40000:], pause])
    truth = synthesize_reference(extract_features(audio), seed=1)
    save_track(truth, tmp_path / "truth.fap")
    (tmp_path / "summary.json").write_text(json.dumps({"conditions": {}}))
    r = CliRunner().invoke(
        main,
        [
            "stimuli",
            "evaluate",
            "--audio",
            str(audio),
            "--ground-truth",
            str(tmp_path / "truth.fap"),
            "--split",
            "0.5",
            "--out",
            str(tmp_path),
        ],
    )
    assert r.exit_code == 0, r.output
    assert "speech_driven" in r.output and (tmp_path / "evaluation.png").stat().st_size > 0
    report = json.loads((tmp_path / "evaluation.json").read_text())
    assert set(report["conditions"]) == {"none", "random", "speech_driven", "ground_truth"}
    assert json.loads((tmp_path / "summary.json").read_text())["evaluation"] == report
    bad = CliRunner().invoke(
        main,
        [
            "stimuli",
            "evaluate",
            "--audio",
            str(audio),
            "--ground-truth",
            str(tmp_path / "truth.fap"),
            "--out",
            str(tmp_path),
        ],
    )
    assert bad.exit_code == 2 and "--split" in bad.output
