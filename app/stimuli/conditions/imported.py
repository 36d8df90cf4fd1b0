"""IMPORTED: a condition a researcher brings as a track per clip (her own system's output, a
capture, a tool's file), treated like every built-in condition.

The file is read by the format facepair recognises (.fap, a FAP .csv, or a tracker's or tool's
file: :func:`app.stimuli.io.load_track`) at the video frame rate, then aligned to the speech as
the ground truth is (thesis sec. 4.3.2, :func:`app.stimuli.track.align_to_features`). What it
keeps as its own is what the study tests (head and eyebrows); its eyes, rest posture and lower
face are replaced by the clip's shared ones in
:func:`app.stimuli.generate.generate_conditions` (:mod:`app.stimuli.shared`), so a track whose
blink columns are 0 never makes a face that stares beside one that blinks.

Example
-------
>>> import numpy as np
>>> from app.stimuli.speech import SpeechFeatures
>>> from app.stimuli.track import MotionTrack
>>> mine = MotionTrack.from_channels(30, {48: np.arange(5.0)})
>>> f = SpeechFeatures(30.0, np.zeros(4), np.zeros(4), np.zeros(4))
>>> ImportedCondition(track=mine, label="mine.fap").generate(f)[48].tolist()
[0.0, 1.0, 2.0, 3.0]
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from app.errors import InputError
from app.stimuli.conditions.base import ConditionModel
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


class ImportedCondition(ConditionModel):
    """A track from a file (or in memory), aligned to the speech.

    track : the file (any format :func:`app.stimuli.io.load_track` reads) or a track.
    label : the name the researcher knows it by (the uploaded file's name); default the
        file's name.
    offset : seconds the track started after the audio (as the ground truth's ``offset``).
    mesh : how to read a mesh or FLAME sequence (:class:`app.stimuli.meshes.source.MeshOptions`
        as a mapping: template, fps, units, regions, pose, flame_model).
    """

    name = "imported"

    def __init__(
        self,
        *,
        track: str | Path | MotionTrack,
        label: str | None = None,
        offset: float = 0.0,
        mesh: Mapping[str, Any] | None = None,
    ) -> None:
        self.track = track
        self.offset = float(offset)
        self.mesh = dict(mesh or {})
        default = track.source or track.name if isinstance(track, MotionTrack) else Path(track).name
        self.label = label or default or "track"
        self._loaded: dict[float, MotionTrack] = {}

    def source_track(self, fps: float) -> MotionTrack:
        """The track as the file holds it (a tool's file imported at ``fps``), read once."""
        if isinstance(self.track, MotionTrack):
            return self.track
        if fps not in self._loaded:
            from app.stimuli.io import load_track

            if not Path(self.track).is_file():
                raise InputError("no such track file", path=self.label)
            try:
                self._loaded[fps] = load_track(self.track, fps=fps, mesh=self.mesh)
            except InputError as exc:
                # the stored copy's path means nothing to the researcher: name her file
                raise InputError(
                    exc.message, path=self.label, line=exc.line, field=exc.field
                ) from None
        return self._loaded[fps]

    def generate(
        self, features: SpeechFeatures, *, seed: int = 0, ground_truth: MotionTrack | None = None
    ) -> MotionTrack:
        source = self.source_track(features.fps)
        if source.n_frames == 0:
            raise InputError("the track has no frames", path=self.label)
        aligned = self.aligned(source, features, self.offset, file=self.label)
        return aligned.replace(name=self.label, source=self.label)

    def describe(self) -> dict[str, Any]:
        return {"file": self.label, "offset_s": self.offset}
