"""NO_PROSODY (thesis sec. 4.3.1): head and eyebrow FAPs set to zero.

Jaw and lips come from the ground truth when there is one; gaze and eyelids follow the study's
``eyes`` setting, as in every condition.
"""

from __future__ import annotations

from app.stimuli.conditions.base import ConditionModel
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


class NoProsodyCondition(ConditionModel):
    """Neutral head and eyebrows: the floor of the comparison."""

    name = "none"

    def generate(
        self, features: SpeechFeatures, *, seed: int = 0, ground_truth: MotionTrack | None = None
    ) -> MotionTrack:
        return self.base_track(features, ground_truth)
