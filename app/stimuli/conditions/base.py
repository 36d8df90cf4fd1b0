"""What every condition shares: the interface and the channels carried over from ground truth.

Thesis sec. 4.3: in all four conditions lip motion comes from the ground truth, since only head
and eyebrow motion are under study. Here the carried channels are jaw and lips and, unless a
condition is asked to keep the eyes neutral, gaze and eyelids; the prosody channels (head 48-50,
eyebrows 31-38) are the condition's own.
"""

from __future__ import annotations

from typing import Any, ClassVar

from app.errors import InputError
from app.stimuli.fap import EYEBROWS, EYELIDS, GAZE, HEAD, JAW_LIPS
from app.stimuli.features import SpeechFeatures
from app.stimuli.track import MotionTrack

#: Channels each condition generates itself (thesis sec. 4.3.1: FAPs 31-34 and 48-50, and the
#: other eyebrow FAPs, which stay neutral where a condition does not drive them).
PROSODY: tuple[int, ...] = EYEBROWS + HEAD
#: Eye channels: carried from the ground truth, or neutral with ``eyes="neutral"``.
EYES: tuple[int, ...] = EYELIDS + GAZE
EYE_MODES = ("ground_truth", "neutral")


class Condition:
    """Base of the condition models (see :mod:`app.stimuli.conditions`)."""

    name: ClassVar[str] = ""

    def __init__(self, *, eyes: str = "ground_truth") -> None:
        if eyes not in EYE_MODES:
            raise InputError(f"eyes must be one of {', '.join(EYE_MODES)}, got {eyes!r}",
                             field="eyes")
        self.eyes = eyes

    def fit(self, features: SpeechFeatures, ground_truth: MotionTrack | None) -> Condition:
        """Learn from speech and ground truth; conditions that learn nothing return self."""
        return self

    def generate(self, features: SpeechFeatures, *, seed: int = 0,
                 ground_truth: MotionTrack | None = None) -> MotionTrack:
        raise NotImplementedError

    def describe(self) -> dict[str, Any]:
        """JSON-able parameters and model facts for the generation summary."""
        return {"eyes": self.eyes}

    # -- helpers for subclasses ---------------------------------------------------------------
    def base_track(self, features: SpeechFeatures, ground_truth: MotionTrack | None
                   ) -> MotionTrack:
        """The carried channels from ``ground_truth`` (aligned) and neutral prosody channels."""
        from app.stimuli.conditions import DISPLAY_NAMES
        from app.stimuli.conditions.ground_truth import align_to_features

        carried: dict[int, Any] = {}
        speaker = ""
        if ground_truth is not None:
            gt = align_to_features(ground_truth, features)
            speaker = gt.speaker
            keep = set(JAW_LIPS) | (set(EYES) if self.eyes == "ground_truth" else set())
            carried = {c: gt[c] for c in gt.channels if c in keep}
        track = MotionTrack.zeros(features.fps, features.n_frames, PROSODY,
                                  name=DISPLAY_NAMES.get(self.name, self.name),
                                  source=f"facepair condition {self.name}", speaker=speaker)
        meta = {"condition": self.name,
                "carried_from_ground_truth": sorted(carried)}
        return track.with_channels(carried).replace(metadata=meta)
