import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.normalize import normalize_tracks
from app.stimuli.track import MotionTrack


def tracks(n=600, seed=0):
    rng = np.random.default_rng(seed)
    gt = MotionTrack.from_channels(
        30.0,
        {
            48: 300 + 1500 * rng.standard_normal(n),
            49: -200 + 2500 * np.sin(np.arange(n) / 40),
            31: np.abs(40 * rng.standard_normal(n)),
        },
    )
    rnd = MotionTrack.from_channels(
        30.0,
        {
            48: 5 + 80 * rng.standard_normal(n),
            49: 9000 + 10 * rng.standard_normal(n),
            31: 3 * rng.random(n),
            3: np.ones(n),
        },
    )
    none = MotionTrack.zeros(30.0, n, (31, 48, 49))
    return {"ground_truth": gt, "random": rnd, "none": none}


def test_mean_and_std_match_the_reference_to_1e_9():
    given = tracks()
    out, factors = normalize_tracks(given)
    ref = given["ground_truth"]
    for c in (48, 49):
        np.testing.assert_allclose(out["random"][c].mean(), ref[c].mean(), rtol=0, atol=1e-9)
        np.testing.assert_allclose(out["random"][c].std(), ref[c].std(), rtol=1e-9, atol=0)
        f = factors["random"][str(c)]
        np.testing.assert_allclose(
            f["scale"] * given["random"][c] + f["offset"], out["random"][c], rtol=1e-12, atol=1e-9
        )
    assert out["ground_truth"] is ref
    np.testing.assert_array_equal(out["random"][3], given["random"][3])  # not a prosody FAP
    # thesis sec. 5.3 scaled the head only: eyebrows keep each condition's own amplitudes
    np.testing.assert_array_equal(out["random"][31], given["random"][31])
    assert "31" not in factors["random"]


def test_eyebrows_are_normalised_only_when_asked():
    given = tracks()
    out, factors = normalize_tracks(given, channels=(48, 49, 50, 31))
    np.testing.assert_allclose(out["random"][31].std(), given["ground_truth"][31].std(), rtol=1e-9)
    assert "scale" in factors["random"]["31"]


def test_constant_channels_and_missing_reference_channels_are_reported():
    given = tracks()
    given["random"] = given["random"].with_channels({50: np.arange(600.0)})
    out, factors = normalize_tracks(given)
    assert factors["none"]["48"]["skipped"] == "constant in this condition"
    assert np.all(out["none"][48] == 0)
    assert factors["random"]["50"]["skipped"] == "reference lacks this channel"


def test_reference_track_given_directly_and_errors():
    given = tracks()
    gt = given.pop("ground_truth")
    out, _ = normalize_tracks(given, gt)
    np.testing.assert_allclose(out["random"][48].std(), gt[48].std(), rtol=1e-9)
    with pytest.raises(InputError, match="not among the conditions"):
        normalize_tracks(given, "ground_truth")
    with pytest.raises(InputError, match="frames"):
        normalize_tracks({"a": gt, "b": gt.fit_length(10)}, "a")
