"""GROUND_TRUTH (thesis sec. 4.3.2): the captured motion, aligned and resampled to the audio.

The capture is aligned by :func:`app.stimuli.track.align_to_features`; ``offset`` (seconds)
shifts it against the audio when the two did not start together (positive: the capture started
``offset`` seconds after the audio), which is why this condition takes the capture as it is.
"""

from __future__ import annotations

from typing import Any

from app.errors import InputError
from app.stimuli.conditions.base import ConditionModel
from app.stimuli.conditions.names import DISPLAY_NAMES
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


class GroundTruthCondition(ConditionModel):
    """The captured (or synthetic reference) motion: the best case of the comparison."""

    name = "ground_truth"

    def __init__(self, *, offset: float = 0.0) -> None:
        self.offset = float(offset)

    def generate(
        self, features: SpeechFeatures, *, seed: int = 0, ground_truth: MotionTrack | None = None
    ) -> MotionTrack:
        if ground_truth is None:
            raise InputError(
                "the ground_truth condition needs a ground-truth track (--ground-truth FILE)",
                field="ground_truth",
            )
        return self.aligned(ground_truth, features, self.offset).replace(
            name=DISPLAY_NAMES[self.name], source=ground_truth.source or "ground truth"
        )

    def describe(self) -> dict[str, Any]:
        return {"offset_s": self.offset}
