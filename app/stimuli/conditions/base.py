"""What every condition shares: the interface and the channels carried over from ground truth.

Thesis sec. 4.3: in all four conditions lip motion comes from the ground truth, since only head
and eyebrow motion are under study. Here the carried channels are jaw and lips; the prosody
channels (head 48-50, eyebrows 31-38) are the condition's own. Gaze and eyelids are set for the
whole study, the same in every condition (:mod:`app.stimuli.eyes`), so that they can never be
what participants judge when a study tests head and eyebrow motion.
"""

from __future__ import annotations

from typing import Any, ClassVar

from app.stimuli.conditions.names import DISPLAY_NAMES
from app.stimuli.fap import EYEBROWS, HEAD, JAW_LIPS
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack, align_to_features

#: Channels each condition generates itself (thesis sec. 4.3.1: FAPs 31-34 and 48-50, and the
#: other eyebrow FAPs, which stay neutral where a condition does not drive them).
PROSODY: tuple[int, ...] = EYEBROWS + HEAD


class ConditionModel:
    """Base of the condition models (see :mod:`app.stimuli.conditions`)."""

    name: ClassVar[str] = ""

    def fit(self, features: SpeechFeatures, ground_truth: MotionTrack | None) -> ConditionModel:
        """Learn from speech and a ground truth aligned to it frame for frame
        (:func:`app.stimuli.track.align_to_features`); conditions that learn nothing return
        self."""
        return self

    def generate(
        self, features: SpeechFeatures, *, seed: int = 0, ground_truth: MotionTrack | None = None
    ) -> MotionTrack:
        """The condition's track for ``features``; ``ground_truth`` is the capture as it is
        (at its own rate and length), aligned here by :meth:`base_track`."""
        raise NotImplementedError

    def describe(self) -> dict[str, Any]:
        """JSON-able parameters and model facts for the generation summary."""
        return {}

    # -- helpers for subclasses ---------------------------------------------------------------
    def aligned(
        self, track: MotionTrack, features: SpeechFeatures, offset: float, **meta: Any
    ) -> MotionTrack:
        """A captured or imported ``track`` aligned to ``features`` (thesis sec. 4.3.2),
        ``offset`` s late, its metadata telling where it came from, and ``meta`` besides."""
        out = align_to_features(track, features, offset)
        meta = dict(
            track.metadata,
            condition=self.name,
            offset_s=offset,
            source_fps=track.fps,
            source_frames=track.n_frames,
            **meta,
        )
        return out.replace(metadata=meta)

    def base_track(self, features: SpeechFeatures, ground_truth: MotionTrack | None) -> MotionTrack:
        """The jaw and lips from ``ground_truth`` (aligned) and neutral prosody channels."""
        carried: dict[int, Any] = {}
        speaker = ""
        if ground_truth is not None:
            gt = align_to_features(ground_truth, features)
            speaker = gt.speaker
            carried = {c: gt[c] for c in gt.channels if c in JAW_LIPS}
        track = MotionTrack.zeros(
            features.fps,
            features.n_frames,
            PROSODY,
            name=DISPLAY_NAMES.get(self.name, self.name),
            source=f"facepair condition {self.name}",
            speaker=speaker,
        )
        meta = {"condition": self.name, "carried_from_ground_truth": sorted(carried)}
        return track.with_channels(carried).replace(metadata=meta)
