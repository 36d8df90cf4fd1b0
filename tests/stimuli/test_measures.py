import numpy as np

from app.stimuli.measures import (
    canonical_correlations,
    channel_stats,
    compare_to_reference,
    head_kinematics,
    measure_track,
    pearson,
)
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


def test_channel_stats_of_a_known_ramp():
    track = MotionTrack.from_channels(30.0, {48: 10.0 * np.arange(31) ** 2 / 2})
    s = channel_stats(track)["48"]
    assert s["mean"] == np.mean(10.0 * np.arange(31) ** 2 / 2)
    np.testing.assert_allclose(s["acceleration_mean_abs"], 10.0 * 30**2)  # x'' = 10 per frame^2
    assert s["acceleration_std"] < 1e-6
    np.testing.assert_allclose(s["velocity_max_abs"], 30 * 5 * (30**2 - 29**2))  # last step


def test_head_speed_of_a_constant_turn():
    deg = np.pi / 180 / 1e-5
    yaw = np.arange(60) * deg / 30 * 10  # 10 degrees per second
    k = head_kinematics(MotionTrack.from_channels(30.0, {49: yaw}))
    np.testing.assert_allclose(k["speed_mean_deg_s"], 10.0)
    np.testing.assert_allclose(k["acceleration_mean_deg_s2"], 0.0, atol=1e-6)


def test_canonical_correlation_known_answers():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((2000, 3))
    y_single = 0.6 * x[:, 0] + rng.standard_normal(2000)
    # one pair: the canonical correlation is |Pearson r|
    cc = canonical_correlations(x[:, :1], y_single[:, None])
    np.testing.assert_allclose(cc[0], abs(pearson(x[:, 0], y_single)), atol=1e-12)
    # Y a full-rank linear map of X: all canonical correlations are 1
    y = x @ rng.standard_normal((3, 3))
    np.testing.assert_allclose(canonical_correlations(x, y), [1, 1, 1], atol=1e-9)
    # independent: near 0; constant columns dropped
    z = rng.standard_normal((2000, 2))
    assert max(canonical_correlations(x, z)) < 0.1
    assert canonical_correlations(np.ones((10, 1)), z[:10]) == []


def test_compare_and_measure_track():
    n = 300
    t = np.arange(n) / 30
    f0c = 150 + 30 * np.sin(t)
    feats = SpeechFeatures(30.0, f0c, 60 + 5 * np.cos(t), f0c)
    gt = MotionTrack.from_channels(30.0, {48: 1000 * np.sin(t), 31: np.zeros(n)})
    track = gt.with_channels({48: 1000 * np.sin(t) + 100})
    cmp = compare_to_reference(track, gt)
    np.testing.assert_allclose(cmp["48"]["rmse"], 100)
    np.testing.assert_allclose(cmp["48"]["correlation"], 1.0)
    assert cmp["31"]["correlation"] is None  # constant: undefined, not NaN
    m = measure_track(track, feats, gt)
    np.testing.assert_allclose(m["speech"]["correlation"]["48"]["f0"], 1.0)
    np.testing.assert_allclose(m["speech"]["canonical_correlation"]["head"][0], 1.0)
    assert set(m) == {"channels", "head", "speech", "ground_truth"}
