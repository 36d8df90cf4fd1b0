"""Gaze and eyelids for a whole study: the same in every condition, so they are no confound.

The thesis (sec. 4.3) and Le, Ma & Deng (2012, sec. 8) compare conditions that differ in
head (and eyebrow) motion only. If one condition carried the captured gaze and blinks and
another generated its own, participants could judge the eyes instead. facepair therefore sets
FAPs 19-26 once per clip and writes the same columns into every condition's track:

- ``still``: open eyes looking ahead, no blinks (all eye FAPs 0). The default, as Le et al.
  kept the eyes out of their head-motion comparisons.
- ``ground_truth``: the captured gaze and eyelids, aligned to the audio (the eye FAPs the
  capture has; those it lacks stay neutral).
- ``generated``: gaze and eyelids from the live model of Le et al. (:mod:`app.stimuli.live`,
  NDCCA gaze and log-normal blinks), generated once from the speech with the study's seed.

Example
-------
>>> import numpy as np
>>> from app.stimuli.speech import SpeechFeatures
>>> f = SpeechFeatures(30.0, np.zeros(4), np.zeros(4), np.zeros(4))
>>> sorted(eye_channels("still", f))[:2], float(eye_channels("still", f)[19].sum())
([19, 20], 0.0)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.errors import InputError
from app.stimuli.fap import EYELIDS, GAZE
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack

#: The eye FAPs a study setting controls: eyelids 19-22 and gaze 23-26.
EYE_CHANNELS: tuple[int, ...] = EYELIDS + GAZE
EYE_MODES: tuple[str, ...] = ("still", "ground_truth", "generated")
DEFAULT_EYES = "still"


def check_eyes(mode: str) -> str:
    """``mode`` if it is one of :data:`EYE_MODES`, else an InputError naming the field."""
    if mode not in EYE_MODES:
        raise InputError(f"eyes must be one of {', '.join(EYE_MODES)}, got {mode!r}", field="eyes")
    return mode


def eye_channels(
    mode: str,
    features: SpeechFeatures,
    ground_truth: MotionTrack | None = None,
    *,
    seed: int = 0,
    live_model_path: str | Path | None = None,
) -> dict[int, np.ndarray]:
    """FAPs 19-26 for every condition of one clip under the study's ``eyes`` setting.

    ``ground_truth`` must already be aligned to ``features`` for ``"ground_truth"``, which
    returns only the eye channels it has; for
    ``"generated"`` the live model at ``live_model_path`` (default: the shipped one) is used.
    """
    check_eyes(mode)
    n = features.n_frames
    if mode == "still":
        return {c: np.zeros(n) for c in EYE_CHANNELS}
    if mode == "ground_truth":
        if ground_truth is None:
            raise InputError("eyes = 'ground_truth' needs a ground-truth track", field="eyes")
        # only the eye channels the capture has: a track passes through unchanged
        return {c: ground_truth[c].copy() for c in EYE_CHANNELS if c in ground_truth.channels}
    from app.stimuli.live.condition import LiveGmmCondition

    live = LiveGmmCondition(model_path=live_model_path).generate(features, seed=seed)
    return {c: live[c].copy() for c in EYE_CHANNELS}
