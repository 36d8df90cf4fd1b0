"""Live model training: the summary, bad training input, takes kept apart."""

from __future__ import annotations

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.live.model import train_live_model
from app.stimuli.live.stream import generate_track
from app.stimuli.track import MotionTrack


def test_training_summary(live_model, live_training_data):
    features, truth = live_training_data
    s = live_model.summary
    assert s["frames"] == features.n_frames and s["fps"] == 30.0 and s["takes"] == 1
    assert s["channels"] == list(truth.channels)
    assert s["voiced_frames"] == int(features.voiced.sum())
    assert s["eyelids"]["blink_source"] == ["fitted", "fitted"]


def test_training_needs_head_motion(live_training_data):
    features, truth = live_training_data
    with pytest.raises(InputError, match="no head motion"):
        train_live_model(features, truth.drop((48, 49, 50)))
    still = truth.with_channels({c: np.zeros(truth.n_frames) for c in (48, 49, 50)})
    with pytest.raises(InputError, match="does not move"):
        train_live_model(features, still)
    short = MotionTrack.zeros(30.0, 50, (48,))
    with pytest.raises(InputError, match="too little"):
        train_live_model(features.slice(0, 50), short)


def test_gazeless_lidless_ground_truth_trains_with_defaults(live_training_data):
    features, truth = live_training_data
    model = train_live_model(
        features.slice(0, 600), truth.select((48, 49, 50)).fit_length(600), n_components=3
    )
    assert not model.gaze.enabled
    assert model.summary["eyelids"]["blink_source"] == ["default", "default"]
    track = generate_track(model, features.slice(0, 100))
    assert np.all(track[23] == 0) and np.all(np.isfinite(track.values))


def test_takes_are_not_joined(live_training_data):
    features, truth = live_training_data
    half = 300  # two 10-s takes
    model = train_live_model(
        [features.slice(0, half), features.slice(half, 2 * half)],
        [
            truth.fit_length(half),
            MotionTrack(truth.fps, truth.values[half : 2 * half], truth.channels),
        ],
        n_components=3,
    )
    assert model.summary["takes"] == 2 and model.summary["frames"] == 2 * half
