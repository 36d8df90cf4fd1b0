import json

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.arx import ArxModel
from app.stimuli.conditions.head_arx import DEFAULT_MODEL_PATH, HeadPoseArx, head_inputs
from app.stimuli.speech import SpeechFeatures, condition_f0
from app.stimuli.track import MotionTrack


def speechlike(n=3000, fps=30.0, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fps
    intensity = 60 + 10 * np.sin(2 * np.pi * 3.7 * t) + 3 * rng.standard_normal(n)
    f0 = np.where(
        np.sin(2 * np.pi * 0.4 * t) > -0.5,
        140 + 30 * np.sin(2 * np.pi * 0.9 * t) + 5 * rng.standard_normal(n),
        0.0,
    )
    return SpeechFeatures(fps, f0, intensity, condition_f0(f0))


def test_inputs_are_the_thesis_five():
    feats = speechlike(300)
    u = head_inputs(feats)
    assert u.shape == (300, 5)
    np.testing.assert_allclose(u[:, 2], feats.intensity * feats.f0_conditioned)


def test_fit_recovers_a_head_system_driven_by_speech():
    feats = speechlike()
    u = head_inputs(feats)
    z = (u - u.mean(0)) / u.std(0)
    rng = np.random.default_rng(5)
    a = np.zeros((4, 3, 3))
    a[0], a[1] = 0.6 * np.eye(3), -0.15 * np.eye(3)
    b = 300 * rng.standard_normal((4, 3, 5))
    truth = ArxModel(a=a, b=b, c=np.array([100.0, -50, 0]), nk=1)
    y = truth.simulate(z, noise=0.5 * rng.standard_normal((len(z), 3)))
    gt = MotionTrack(30.0, y, (48, 49, 50), source="test system")
    model = HeadPoseArx.fit(feats, gt)
    np.testing.assert_allclose(model.arx.a, a, atol=0.02)
    np.testing.assert_allclose(model.arx.b[:, :, :3], b[:, :, :3], atol=5)
    # the 1-s means barely change within 4 frames: only their summed lag weight is identified
    np.testing.assert_allclose(model.arx.b[:, :, 3:].sum(0), b[:, :, 3:].sum(0), atol=5)
    head = model.generate(feats)
    clean = truth.simulate(z)
    assert np.corrcoef(head[48], clean[:, 0])[0, 1] > 0.99


def test_other_frame_rate_runs_at_the_models_rate():
    feats = speechlike(900)
    gt = MotionTrack(30.0, np.column_stack([np.sin(np.arange(900) / 20) * 1000] * 3), (48, 49, 50))
    model = HeadPoseArx.fit(feats, gt)
    feats25 = SpeechFeatures(
        25.0,
        feats.f0[::6].repeat(5),
        feats.intensity[::6].repeat(5),
        feats.f0_conditioned[::6].repeat(5),
    )
    head = model.generate(feats25)
    assert len(head[48]) == feats25.n_frames and np.isfinite(head[48]).all()


def test_save_load_round_trip_and_damaged_files(tmp_path):
    feats = speechlike(600)
    gt = MotionTrack(30.0, np.random.default_rng(1).standard_normal((600, 3)) * 500, (48, 49, 50))
    model = HeadPoseArx.fit(feats, gt)
    model.save(tmp_path / "m.json")
    again = HeadPoseArx.load(tmp_path / "m.json")
    np.testing.assert_allclose(again.generate(feats)[49], model.generate(feats)[49], rtol=1e-12)
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(InputError, match="not a JSON head model"):
        HeadPoseArx.load(tmp_path / "bad.json")
    d = json.loads((tmp_path / "m.json").read_text())
    d["format"] = "other"
    (tmp_path / "other.json").write_text(json.dumps(d))
    with pytest.raises(InputError, match="not a facepair head model"):
        HeadPoseArx.load(tmp_path / "other.json")
    d["format"] = "facepair-head-arx"
    del d["arx"]["b"]
    (tmp_path / "cut.json").write_text(json.dumps(d))
    with pytest.raises(InputError, match="damaged head model"):
        HeadPoseArx.load(tmp_path / "cut.json")


def test_short_recording_is_stabilised_or_refused():
    feats = speechlike(60)
    gt = MotionTrack(
        30.0, np.cumsum(np.random.default_rng(2).standard_normal((60, 3)), 0) * 300, (48, 49, 50)
    )
    model = HeadPoseArx.fit(feats, gt)
    assert model.arx.spectral_radius() < 0.995
    with pytest.raises(InputError, match="cannot fit the head model"):
        HeadPoseArx.fit(feats.slice(0, 20), gt.fit_length(20))


def test_shipped_default_model_loads():
    model = HeadPoseArx.load(DEFAULT_MODEL_PATH)
    assert model.arx.na == 4 and model.arx.nb == 4 and model.arx.nk == 1
    assert model.arx.spectral_radius() < 1
    assert "demo" in model.provenance["fitted_on"]
