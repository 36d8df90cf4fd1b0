import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.conditions import make_condition
from app.stimuli.conditions.head_arx import DEFAULT_MODEL_PATH
from app.stimuli.conditions.speech_driven import resolve_threshold
from app.stimuli.features import SpeechFeatures
from app.stimuli.reference_speaker import synthesize_reference
from tests.stimuli.conditions.test_eyebrow_rule import known_contours


def known_features():
    f0, intensity = known_contours()
    return SpeechFeatures(30.0, f0, intensity, f0.copy())


def test_rule_eyebrows_and_default_head_model_without_ground_truth():
    feats = known_features()
    cond = make_condition("speech_driven")
    track = cond.generate(feats)
    assert track.name == "SPEECH_DRIVEN"
    info = track.metadata["eyebrows"]
    assert info["raises"] == [[10, 30], [60, 80], [100, 109]]
    np.testing.assert_allclose(track[31][10:30], 0.5 * feats.f0_conditioned[18])
    np.testing.assert_allclose(track[33][60:80], 0.8 * 0.5 * 230)
    assert "default head model" in track.metadata["head_model"]
    assert DEFAULT_MODEL_PATH.name in cond.describe()["head_model"]
    assert np.isfinite(track[48]).all() and track[48].std() > 0


def test_no_raise_warns():
    feats = known_features()
    track = make_condition("speech_driven", f0_threshold=400).generate(feats)
    assert track.metadata["eyebrows"]["n_raises"] == 0
    assert "never rises across 400 Hz" in track.metadata["eyebrows"]["warning"]


def test_auto_thresholds():
    feats = known_features()
    assert resolve_threshold("auto", "f0", feats) == np.percentile(feats.f0_conditioned, 75)
    assert resolve_threshold("210", "f0", feats) == 210.0
    with pytest.raises(InputError, match="number or 'auto'"):
        resolve_threshold("high", "f0", feats)


def phrase_features(seconds=120.0, fps=30.0):
    rng = np.random.default_rng(0)
    n = round(seconds * fps)
    t = np.arange(n) / fps
    talking = (t % 4.0) < 3.0
    intensity = np.where(talking, 62 + 8 * np.sin(2 * np.pi * 3.5 * t), 38.0)
    intensity += rng.normal(0, 1, n)
    f0c = 170 + 50 * np.sin(2 * np.pi * 0.6 * t) ** 8 + 10 * np.sin(2 * np.pi * 0.21 * t)
    return SpeechFeatures(fps, np.where(talking, f0c, 0.0), intensity, f0c)


def test_fitted_on_reference_speaker_learns_speech_structure():
    """Fitted on the synthetic speaker, the model beats its own seed-shuffled baseline."""
    feats = phrase_features()
    gt = synthesize_reference(feats, seed=3)
    half = feats.n_frames // 2
    train, test = feats.slice(0, half), feats.slice(half, feats.n_frames)
    cond = make_condition("speech_driven").fit(train, gt.fit_length(half))
    assert "fitted on the ground truth" in cond.describe()["head_model"]
    pred = cond.generate(test)
    truth = gt.replace(values=gt.values[half:])
    # the synthetic head pitch has a speech-driven part, so held-out prediction correlates
    r = np.corrcoef(pred[48], truth[48])[0, 1]
    assert r > 0.3, r


def test_eyebrow_gains_fitted_from_ground_truth():
    feats = known_features()
    gt = make_condition("speech_driven", eyebrow_gain=0.3, eyebrow_offset=10).generate(feats)
    cond = make_condition("speech_driven").fit(feats, gt)
    assert cond.brows_fitted
    np.testing.assert_allclose(cond.brow_gain[31], 0.3, atol=1e-9)
    np.testing.assert_allclose(cond.brow_offset[33], 8.0, atol=1e-9)
