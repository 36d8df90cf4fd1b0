"""What a study does not test, made the same in every condition (``app.stimuli.untested``)."""

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.fap import EYEBROWS
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack
from app.stimuli.untested import share_untested

N = 30


def _features() -> SpeechFeatures:
    f0 = np.where(np.arange(N) % 10 < 6, 120.0, np.nan)
    return SpeechFeatures(30.0, f0, np.full(N, 60.0), np.where(np.isnan(f0), 150.0, f0), {})


def _tracks() -> dict[str, MotionTrack]:
    t = np.arange(N, dtype=float)
    return {
        "a": MotionTrack.from_channels(30, {48: np.sin(t), 31: t, 3: t * 2, 19: t}),
        "b": MotionTrack.from_channels(30, {48: np.cos(t), 4: np.ones(N)}),
    }


def _share(tracks, **settings):
    kw = dict(eyes="still", posture="per_condition", lips="shared", brows="own", mesh_eyes="match")
    notes: list[str] = []
    kw |= settings
    out, shared = share_untested(tracks, [], _features(), None, seed=0, notes=notes, **kw)
    return out, shared, notes


def test_every_channel_but_the_tested_is_the_same_in_every_condition():
    out, shared, notes = _share(_tracks())
    for c in set(out["a"].channels) | set(out["b"].channels):
        if c not in (48, 49, 50, *EYEBROWS):
            assert np.array_equal(out["a"].get(c), out["b"].get(c)), c
    assert not np.array_equal(out["a"].get(48), out["b"].get(48))
    assert shared["eyes_from"] == "still"
    assert shared["brows"] == {"mode": "own", "from": "each condition's own"}
    assert shared["posture"] == {"mode": "per_condition", "rest_head_au": None, "rest_from": None}
    assert "mesh_eyes" not in shared and notes == []


def test_own_lips_are_kept_and_said_and_no_brows_are_none():
    out, shared, notes = _share(_tracks(), lips="own", brows="none")
    assert out["a"].get(3).tolist() == (np.arange(N) * 2.0).tolist()
    assert shared["lips"]["mode"] == "own" and "lips = 'own'" in notes[0]
    assert not out["a"].get(31).any()


def test_the_shared_posture_without_a_ground_truth_is_neutral():
    _, shared, _ = _share(_tracks(), posture="shared")
    assert shared["posture"]["rest_from"] == "neutral"


def test_own_eyes_need_eye_motion_in_every_condition():
    with pytest.raises(InputError, match="condition b carries no eye motion"):
        _share(_tracks(), eyes="own")
