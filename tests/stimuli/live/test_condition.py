"""The live_gmm condition: registry, default model, tracks; it learns from the reference speaker
(held-out head motion correlates with the ground truth better than the random condition's)."""

from __future__ import annotations

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.conditions import DISPLAY_NAMES, make_condition
from app.stimuli.live.condition import DEFAULT_MODEL_PATH, LiveGmmCondition
from app.stimuli.live.modelfile import save_model
from app.stimuli.live.stream import generate_track
from app.stimuli.reference_speaker import synthesize_reference


def test_registry_makes_the_live_condition():
    cond = make_condition("live_gmm")
    assert isinstance(cond, LiveGmmCondition) and cond.name == "live_gmm"
    assert DISPLAY_NAMES["live_gmm"] == "LIVE_GMM"


def test_default_model_ships_and_generates(live_training_data):
    assert DEFAULT_MODEL_PATH.exists()
    features = live_training_data[0].slice(0, 150)
    track = LiveGmmCondition().generate(features, seed=1)
    assert {19, 20, 21, 22, 23, 24, 25, 26, 48, 49, 50} <= set(track.channels)
    assert track.n_frames == 150 and np.all(np.isfinite(track.values))
    assert np.std(track[48]) > 0 and np.std(track[23]) > 0
    assert track.metadata["model_training"]["audio"] == ["data/demo/speech.wav"]


def test_ground_truth_lips_are_carried_and_eyes_are_the_models(live_model, live_training_data):
    features, truth = live_training_data
    jaw = truth.with_channels({3: np.linspace(0, 300, truth.n_frames)})
    cond = LiveGmmCondition()
    cond.model = live_model
    track = cond.generate(features.slice(0, 200), seed=0, ground_truth=jaw)
    np.testing.assert_allclose(track[3], jaw[3][:200])
    assert not np.allclose(track[23], truth[23][:200])
    assert cond.describe()["training"]["frames"] == features.n_frames


def test_missing_model_file_is_one_line(tmp_path, live_training_data):
    cond = LiveGmmCondition(model_path=tmp_path / "none.npz")
    with pytest.raises(InputError, match="train-live"):
        cond.generate(live_training_data[0].slice(0, 10))


def _head_correlation(track, truth) -> float:
    return float(np.mean([np.corrcoef(track[c], truth[c])[0, 1] for c in (48, 49, 50)]))


@pytest.mark.slow
def test_learns_head_motion_of_the_reference_speaker_better_than_random(
    live_training_data, live_held_out_speech
):
    # Train on one stretch of speech with the reference speaker's motion (version 2, whose
    # head carries a speech relation in every angle); test on other speech against the
    # reference motion of six other seeds, which the models never saw. (Against one seed of
    # version 1 this test once passed on a lucky draw: over 20 seeds the Langevin model's mean
    # r was 0.03 / 0.02 / 0.02, that seed's yaw 0.55.)
    train_speech = live_training_data[0]
    train_truth = synthesize_reference(train_speech, seed=0, version=2)
    held = [synthesize_reference(live_held_out_speech, seed=s, version=2) for s in range(3, 9)]
    live = make_condition("live_gmm").fit(train_speech, train_truth)
    rand = make_condition("random").fit(train_speech, train_truth)

    def mean_r(cond) -> np.ndarray:
        tracks = [cond.generate(live_held_out_speech, seed=s) for s in range(2)]
        return np.mean(
            [[np.corrcoef(t[c], h[c])[0, 1] for c in (48, 49, 50)] for t in tracks for h in held],
            axis=0,
        )

    r_live, r_rand = mean_r(live), mean_r(rand)
    # measured: live 0.12 / 0.43 / 0.73 (pitch / yaw / roll), random within +/- 0.05
    assert np.all(r_live > r_rand + 0.05), (r_live, r_rand)
    assert np.all(r_live > 0.08) and r_live.mean() > 0.3, r_live


def test_fit_without_ground_truth_keeps_the_file_model(tmp_path, live_model, live_training_data):
    path = save_model(live_model, tmp_path / "m.npz")
    cond = make_condition("live_gmm", model_path=str(path))
    assert cond.fit(live_training_data[0], None) is cond
    features = live_training_data[0].slice(0, 60)
    np.testing.assert_array_equal(
        cond.generate(features, seed=2)[48], generate_track(live_model, features, seed=2)[48]
    )
    assert cond.describe()["model"] == str(path)


def test_a_given_model_file_is_used_instead_of_fitting(tmp_path, live_model, live_training_data):
    features, truth = live_training_data
    path = save_model(live_model, tmp_path / "m.npz")
    cond = make_condition("live_gmm", model_path=path).fit(features, truth.drop((48,)))
    assert cond.model is None and "given model file" in cond.describe()["note"]
    short = features.slice(0, 60)
    np.testing.assert_array_equal(
        cond.generate(short, seed=1)[49], generate_track(live_model, short, seed=1)[49]
    )


def test_unusable_ground_truth_falls_back_to_the_default_model(live_training_data):
    features, truth = live_training_data
    cond = LiveGmmCondition().fit(features, truth.select((19, 20, 21, 22)))
    assert "no head motion" in cond.describe()["note"]
    track = cond.generate(features.slice(0, 30))
    assert track.metadata["model_path"] == str(DEFAULT_MODEL_PATH)
    fitted = LiveGmmCondition(n_components=3).fit(features.slice(0, 300), truth.fit_length(300))
    assert fitted.describe()["model"] == "fitted"
    assert fitted.generate(features.slice(0, 30)).metadata["model_note"].startswith("model fit")
