"""GROUND_TRUTH (thesis sec. 4.3.2): the captured motion, aligned and resampled to the audio.

The captured track is resampled to the video frame rate of the features (low-passed first when
downsampling, e.g. 120 Hz capture -> 30 fps) and cut or padded to the audio's frame count.
``offset`` (seconds) shifts the capture against the audio when the two did not start together:
a positive offset means the capture started ``offset`` seconds after the audio.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.conditions.base import ConditionModel
from app.stimuli.features import SpeechFeatures
from app.stimuli.track import MotionTrack


def align_to_features(track: MotionTrack, features: SpeechFeatures, offset: float = 0.0
                      ) -> MotionTrack:
    """``track`` at the features' frame rate and frame count, shifted by ``offset`` seconds.

    Frames before the capture starts hold its first frame; frames after it ends hold its last.
    """
    r = track.resample(features.fps)
    shift = round(offset * features.fps)
    if shift > 0:
        r = r.replace(values=np.vstack([np.repeat(r.values[:1], shift, axis=0), r.values]))
    elif shift < 0:
        r = r.replace(values=r.values[-shift:].copy())
    return r.fit_length(features.n_frames)


class GroundTruthCondition(ConditionModel):
    """The captured (or synthetic reference) motion: the best case of the comparison."""

    name = "ground_truth"

    def __init__(self, *, offset: float = 0.0) -> None:
        self.offset = float(offset)

    def generate(self, features: SpeechFeatures, *, seed: int = 0,
                 ground_truth: MotionTrack | None = None) -> MotionTrack:
        if ground_truth is None:
            raise InputError("the ground_truth condition needs a ground-truth track "
                             "(--ground-truth FILE)", field="ground_truth")
        from app.stimuli.conditions import DISPLAY_NAMES

        gt = align_to_features(ground_truth, features, self.offset)
        meta = dict(gt.metadata, condition=self.name, offset_s=self.offset,
                    source_fps=ground_truth.fps, source_frames=ground_truth.n_frames)
        return gt.replace(name=DISPLAY_NAMES[self.name], source=ground_truth.source or
                          "ground truth", metadata=meta)

    def describe(self) -> dict[str, Any]:
        return {"offset_s": self.offset}
