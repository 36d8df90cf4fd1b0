"""One rest posture for every condition of a clip, so that posture is never what is judged.

A condition that is generated around the neutral pose (NO_PROSODY, RANDOM) faces the camera;
the ground truth, and the SPEECH_DRIVEN head that takes its mean, carry the capture's posture:
4.4 deg on the demo speaker, 15-20 deg for an OpenFace take, whose pose is relative to the
camera. In a paired comparison participants then see which face is turned, not which moves
with the speech. The thesis' comparisons were meant to differ in the motion alone (sec. 4.3).

``posture`` of a generation (:func:`app.stimuli.generate.generate_conditions`, ``--posture``,
``posture`` in a study file's ``[stimuli]``):

- ``shared`` (default): every condition's head angles (FAP 48-50) are shifted by a constant so
  that their median is the ground truth's median head pose, the ground truth's rest (the pose
  its head keeps most of the time, robust to the nods and turns around it); without a ground
  truth, the neutral pose 0. The motion of each condition is untouched; NO_PROSODY holds the
  rest pose, GROUND_TRUTH is unchanged (its median is the rest by definition).
- ``per_condition``: each condition keeps its own posture, as in the thesis' experiment 1
  (sec. 5.2, Table 8: the head means of the conditions differ by up to 4 deg of yaw).

Example
-------
>>> import numpy as np
>>> from app.stimuli.track import MotionTrack
>>> gt = MotionTrack.from_channels(30, {48: np.array([100.0, 100.0, 400.0])})
>>> flat = MotionTrack.from_channels(30, {48: np.zeros(3)})
>>> rest = rest_posture(gt)
>>> rest[48], share_posture({"none": flat}, rest)["none"][48].tolist()
(100.0, [100.0, 100.0, 100.0])
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from app.errors import InputError
from app.stimuli.fap import HEAD
from app.stimuli.track import MotionTrack

POSTURES: tuple[str, ...] = ("shared", "per_condition")
DEFAULT_POSTURE = "shared"


def check_posture(mode: str) -> str:
    """``mode`` if it is one of :data:`POSTURES`, else an InputError naming the field."""
    if mode not in POSTURES:
        raise InputError(
            f"posture must be one of {', '.join(POSTURES)}, got {mode!r}", field="posture"
        )
    return mode


def rest_posture(ground_truth: MotionTrack | None) -> dict[int, float]:
    """The rest head pose {FAP 48-50: AU}: the ground truth's per-angle median, else 0."""
    rest = {c: 0.0 for c in HEAD}
    if ground_truth is not None and ground_truth.n_frames:
        for c in HEAD:
            if c in ground_truth.channels:
                rest[c] = float(np.median(ground_truth[c]))
    return rest


def share_posture(
    tracks: Mapping[str, MotionTrack], rest: Mapping[int, float]
) -> dict[str, MotionTrack]:
    """Each track with its head angles shifted so that their median is ``rest``.

    A track without a head channel gets it, constant at the rest pose (a FAP absent from a
    track is neutral, which would not be the shared rest).
    """
    out: dict[str, MotionTrack] = {}
    for name, track in tracks.items():
        cols = {}
        for c in HEAD:
            x = track.get(c)
            shift = rest[c] - (float(np.median(x)) if len(x) else 0.0)
            cols[c] = x + shift
        out[name] = track.with_channels(cols)
    return out
