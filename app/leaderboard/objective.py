"""Objective measures published beside the scores (never mixed into them).

Per system, averaged over the segments, of the head motion as participants saw it (the track a
round renders) against the segment's speech and ground truth:

- ``head_speed_deg_s``: mean angular speed of the head (Le, Ma & Deng 2012's kinematics,
  :func:`app.stimuli.measures.head_kinematics`);
- ``head_jitter``: share of the head angles' power above 4 Hz (Welch;
  :func:`app.stimuli.evaluate.power_above`): natural head motion has little there;
- ``head_speech_cc``: first canonical correlation of the head angles with the conditioned F0
  and intensity (:func:`app.stimuli.evaluate.coupling`);
- ``head_truth_r``: Pearson correlation with the ground truth's head angles, averaged over
  pitch, yaw and roll (a speech-driven system need not follow one take, so a low value is no
  verdict: the benchmark paper on speech-driven 3D faces found such measures and listeners
  often disagree).

LSE-D/LSE-C (SyncNet on video) are meaningless under the mouth mosaic and are not computed.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from app.stimuli.evaluate import coupling, power_above
from app.stimuli.fap import HEAD
from app.stimuli.measures import head_kinematics, pearson
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack, align_to_features


def _mean(values: list[float | None]) -> float | None:
    kept = [v for v in values if v is not None and np.isfinite(v)]
    return round(float(np.mean(kept)), 4) if kept else None


def objective_measures(
    tracks: Mapping[str, MotionTrack],
    truths: Mapping[str, MotionTrack],
    features: Mapping[str, SpeechFeatures],
) -> dict[str, Any]:
    """The measures of one system from its track, ground truth and speech per segment."""
    speed, jitter, cc, truth_r = [], [], [], []
    for segment, track in tracks.items():
        feats = features[segment]
        aligned = align_to_features(track, feats)
        truth = align_to_features(truths[segment], feats)
        speed.append(head_kinematics(aligned)["speed_mean_deg_s"])
        jitter.append(_mean([power_above(aligned.get(c), aligned.fps) for c in HEAD]))
        cc.append(coupling(aligned, feats)["head"])
        truth_r.append(_mean([pearson(aligned.get(c), truth.get(c)) for c in HEAD]))
    return {
        "head_speed_deg_s": _mean(speed),
        "head_jitter": _mean(jitter),
        "head_speech_cc": _mean(cc),
        "head_truth_r": _mean(truth_r),
    }


#: What each measure is, for the page's table.
MEASURES = {
    "head_speed_deg_s": "head speed, deg/s",
    "head_jitter": "head power above 4 Hz",
    "head_speech_cc": "head-speech canonical correlation",
    "head_truth_r": "correlation with the ground truth's head",
}
