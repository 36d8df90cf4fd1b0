"""Gaze and eyelids for a whole study: the same in every condition, so they are no confound.

The thesis (sec. 4.3) and Le, Ma & Deng (2012, sec. 8) compare conditions that differ in
head (and eyebrow) motion only. If one condition carried the captured gaze and blinks and
another generated its own, participants could judge the eyes instead. facepair therefore sets
FAPs 19-26 once per clip and writes the same columns into every condition's track, so both
faces of a pair blink and move their eyes together:

- ``generated`` (the default): gaze and eyelids from the live model of Le et al. (sec. 6-7,
  :mod:`app.stimuli.live`: NDCCA gaze with fixations, log-normal blinks), generated once
  from the speech with the study's seed. When the conditions include ``live_gmm``,
  :func:`app.stimuli.generate.generate_conditions` takes that condition's own gaze and blinks
  instead, so the live model keeps its eyes and every other face gets the same ones. A face
  that never blinks in 15 s is the first thing a participant notices; people blink about
  15-20 times a minute while talking (L sec. 7.1).
- ``still``: open eyes looking ahead, no blinks (all eye FAPs 0): the thesis' faces, whose eyes
  did not move, and Le et al.'s head-only comparisons.
- ``ground_truth``: the captured gaze and eyelids, aligned to the audio (the eye FAPs the
  capture has; those it lacks stay neutral).
- ``own``: each condition keeps its own eyes, for a study that compares eye motion (imported
  systems that each model gaze and blinks). Every condition must then carry eye motion: one
  without (the built-in thesis conditions, a track whose eye columns are 0) is refused, named.

Conditions a researcher imports are no exception: under every mode but ``own`` their eye
channels are replaced like any other condition's (:mod:`app.stimuli.shared`).

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
EYE_MODES: tuple[str, ...] = ("still", "ground_truth", "generated", "own")
DEFAULT_EYES = "generated"


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
    """FAPs 19-26 for every condition of one clip under the study's ``eyes`` setting (not
    ``own``, which keeps each condition's).

    ``ground_truth`` must already be aligned to ``features`` for ``"ground_truth"``, which
    returns only the eye channels it has; for
    ``"generated"`` the live model at ``live_model_path`` (default: the shipped one) is used.
    """
    if check_eyes(mode) == "own":
        raise ValueError("eyes = 'own' sets no shared eye channels")
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
