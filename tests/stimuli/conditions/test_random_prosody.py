import numpy as np

from app.stimuli.conditions import make_condition
from app.stimuli.perlin import fbm_bound
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


def features(seconds=60.0, fps=30.0):
    n = round(seconds * fps)
    return SpeechFeatures(fps, np.full(n, 120.0), np.full(n, 60.0), np.full(n, 120.0))


def test_deterministic_per_seed():
    feats = features(20)
    cond = make_condition("random")
    a, b = cond.generate(feats, seed=3), cond.generate(feats, seed=3)
    assert a.equals(b) and a.name == "RANDOM"
    assert not a.equals(cond.generate(feats, seed=4))


def test_eyebrows_non_negative_and_symmetric_head_channels_independent():
    track = make_condition("random").generate(features(), seed=1)
    for c in range(31, 37):
        assert track[c].min() >= 0
    assert (track[31] > 0).mean() > 0.2 and (track[31] == 0).mean() > 0.2  # clipped half
    np.testing.assert_array_equal(track[31], track[32])
    corr = np.corrcoef([track[48], track[49], track[50]])
    assert np.all(np.abs(corr[np.triu_indices(3, 1)]) < 0.5)
    assert np.all(track[37] == 0) and np.all(track[38] == 0)


def test_default_amplitudes_are_the_thesis_perlin_constants():
    track = make_condition("random").generate(features(), seed=2)
    # Table 8, RANDOM rows, mean of S2 and S7
    for c, sd in ((48, 3590.0), (49, 4350.0), (50, 3050.0), (31, 12.5), (33, 12.5)):
        np.testing.assert_allclose(track[c].std(), sd, rtol=1e-9)
    assert abs(track[49].mean()) < 1e-6  # around the neutral pose
    assert np.all(track[35] == 0) and np.all(track[36] == 0)  # no outer-eyebrow markers
    np.testing.assert_array_equal(track[31], track[33])  # inner = middle


def reference_track(n):
    rng = np.random.default_rng(0)
    return MotionTrack.from_channels(
        30.0,
        {
            48: 400 + 900 * rng.standard_normal(n),
            49: -100 + 2000 * rng.standard_normal(n),
            50: 300 * rng.standard_normal(n),
            31: np.abs(5 * rng.standard_normal(n)),
        },
        source="capture",
    )


def test_experiment_1_random_keeps_its_own_amplitudes_next_to_a_ground_truth():
    """Thesis sec. 5.2: RANDOM moved more than the ground truth (Table 8); fitting on a small
    ground truth must not shrink it."""
    feats = features(30)
    ref = reference_track(feats.n_frames)
    track = make_condition("random").fit(feats, ref).generate(feats, seed=5)
    assert track[49].std() > 2 * ref[49].std()
    np.testing.assert_allclose(track[49].std(), 4350.0, rtol=1e-9)
    assert "Table 8" in track.metadata["amplitudes"]


def test_amplitudes_matched_to_a_reference_on_request():
    feats = features(30)
    ref = reference_track(feats.n_frames)
    track = make_condition("random", match_amplitudes=True).fit(feats, ref).generate(feats, seed=5)
    for c in (48, 49, 50):
        np.testing.assert_allclose(track[c].mean(), ref[c].mean(), atol=1e-9 * 1e4)
        np.testing.assert_allclose(track[c].std(), ref[c].std(), rtol=1e-9)
    np.testing.assert_allclose(track[31].std(), ref[31].std(), rtol=1e-9)
    assert track[31].min() >= 0 and "capture" in track.metadata["amplitudes"]


def test_noise_parameters_reach_the_generator():
    feats = features(10)
    one = make_condition("random", octaves=1, persistence=0.5).generate(feats, seed=1)
    six = make_condition("random").generate(feats, seed=1)
    assert np.std(np.diff(one[48])) < np.std(np.diff(six[48]))
    assert fbm_bound(1, 0.5) == 0.5
