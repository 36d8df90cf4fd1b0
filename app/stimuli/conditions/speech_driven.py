"""SPEECH_DRIVEN (thesis sec. 4.3.4): eyebrows by rule, head by an ARX model, from speech alone.

- Eyebrows (FAP 31-36): :mod:`app.stimuli.conditions.eyebrow_rule`. Raise sizes are
  ``gain * F0peak + offset`` per channel; by default one gain for all with the middle and outer
  eyebrows at 0.8 and 0.5 of the inner ones; :meth:`SpeechDrivenCondition.fit` fits gain and
  offset per channel by least squares on the ground-truth eyebrows during the rule's raises.
- Head (FAP 48-50): :mod:`app.stimuli.conditions.head_arx`, fitted on ground truth by
  :meth:`fit`, else read from ``model_path``, else the shipped default model (fitted on the
  demo data) - the track's metadata and the summary say which.

The F0 and intensity thresholds take a number or ``"auto"``: the thesis' 207 Hz and 45 dB suit
its speakers and recording gain; ``"auto"`` picks the 75th percentile of the speaker's voiced
conditioned F0 and the level 35 % of the way from the noise floor (10th percentile of
intensity) to the speech level (90th percentile).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.conditions.base import Condition
from app.stimuli.conditions.eyebrow_rule import (
    F0_THRESHOLD_HZ,
    INTENSITY_THRESHOLD_DB,
    MIN_HOLD_S,
    RELEASE_FRAMES,
    eyebrow_contour,
    eyebrow_raise_events,
    eyebrow_raise_sizes,
)
from app.stimuli.conditions.ground_truth import align_to_features
from app.stimuli.conditions.head_arx import DEFAULT_MODEL_PATH, HeadPoseArx
from app.stimuli.fap import EYEBROW_RAISE, HEAD
from app.stimuli.features import SpeechFeatures
from app.stimuli.track import MotionTrack

#: Default eyebrow raise per channel relative to the inner eyebrows (31, 32).
BROW_RATIO = {31: 1.0, 32: 1.0, 33: 0.8, 34: 0.8, 35: 0.5, 36: 0.5}


def resolve_threshold(value: float | str, kind: str, features: SpeechFeatures) -> float:
    """A number, or ``"auto"`` adapted to this recording (see the module docstring)."""
    if isinstance(value, str):
        if value.strip().lower() != "auto":
            try:
                return float(value)
            except ValueError:
                raise InputError(f"expected a number or 'auto', got {value!r}",
                                 field=f"{kind}_threshold") from None
        if kind == "f0":
            voiced = features.f0_conditioned[features.voiced]
            return float(np.percentile(voiced, 75)) if len(voiced) else F0_THRESHOLD_HZ
        floor, level = np.percentile(features.intensity, [10, 90])
        return float(floor + 0.35 * (level - floor))
    return float(value)


class SpeechDrivenCondition(Condition):
    """The thesis' speech-driven visual prosody."""

    name = "speech_driven"

    def __init__(self, *, f0_threshold: float | str = F0_THRESHOLD_HZ,
                 intensity_threshold: float | str = INTENSITY_THRESHOLD_DB,
                 min_hold_s: float = MIN_HOLD_S, release_frames: int = RELEASE_FRAMES,
                 eyebrow_gain: float = 0.5, eyebrow_offset: float = 0.0,
                 na: int = 4, nb: int = 4, nk: int = 1, ridge: float = 0.0,
                 model_path: str | Path | None = None, eyes: str = "ground_truth") -> None:
        super().__init__(eyes=eyes)
        if min_hold_s < 0 or release_frames < 0 or na < 0 or nb < 1 or nk < 0:
            raise InputError("min_hold_s, release_frames, na, nk must be >= 0 and nb >= 1",
                             field="speech_driven")
        self.f0_threshold, self.intensity_threshold = f0_threshold, intensity_threshold
        self.min_hold_s, self.release_frames = float(min_hold_s), int(release_frames)
        self.brow_gain = {c: eyebrow_gain * r for c, r in BROW_RATIO.items()}
        self.brow_offset = {c: eyebrow_offset * r for c, r in BROW_RATIO.items()}
        self.brows_fitted = False
        self.order = dict(na=int(na), nb=int(nb), nk=int(nk), ridge=float(ridge))
        self.model_path = model_path
        self.head: HeadPoseArx | None = None
        self.head_note = ""

    # -- eyebrows ------------------------------------------------------------------------------
    def _events(self, features: SpeechFeatures) -> tuple[list[tuple[int, int]], float, float]:
        f0_thr = resolve_threshold(self.f0_threshold, "f0", features)
        db_thr = resolve_threshold(self.intensity_threshold, "intensity", features)
        events = eyebrow_raise_events(features.f0_conditioned, features.intensity, features.fps,
                                      f0_threshold=f0_thr, intensity_threshold=db_thr,
                                      min_hold_s=self.min_hold_s)
        return events, f0_thr, db_thr

    def eyebrows(self, features: SpeechFeatures) -> tuple[dict[int, np.ndarray], dict[str, Any]]:
        """Eyebrow columns and a JSON-able account of the raises."""
        events, f0_thr, db_thr = self._events(features)
        peaks = eyebrow_raise_sizes(features.f0_conditioned, events, features.fps,
                                    self.min_hold_s)
        cols = {}
        for c in EYEBROW_RAISE:
            sizes = np.maximum(self.brow_gain[c] * peaks + self.brow_offset[c], 0.0)
            cols[c] = eyebrow_contour(features.n_frames, events, sizes, self.release_frames)
        info = {"f0_threshold_hz": f0_thr, "intensity_threshold_db": db_thr,
                "raises": [[s, r] for s, r in events], "n_raises": len(events)}
        if not events:
            top = float(features.f0_conditioned.max()) if features.n_frames else 0.0
            info["warning"] = (f"no eyebrow raise: conditioned F0 never rises across "
                               f"{f0_thr:g} Hz (its maximum is {top:.0f} Hz); set the F0 "
                               "threshold for this speaker or use 'auto'")
        return cols, info

    def _fit_brows(self, features: SpeechFeatures, gt: MotionTrack) -> None:
        events, _, _ = self._events(features)
        if not events:
            return
        peaks = eyebrow_raise_sizes(features.f0_conditioned, events, features.fps,
                                    self.min_hold_s)
        frames = np.concatenate([np.arange(s, r) for s, r in events])
        peak_of_frame = np.concatenate([np.full(r - s, p) for (s, r), p in zip(events, peaks,
                                                                               strict=True)])
        distinct = len(np.unique(np.round(peaks, 6))) >= 2
        for c in EYEBROW_RAISE:
            if c not in gt.channels:
                continue
            y = gt[c][frames]
            if distinct:
                x = np.column_stack([peak_of_frame, np.ones(len(frames))])
                (gain, offset), *_ = np.linalg.lstsq(x, y, rcond=None)
            else:  # one raise height: a pure gain through the origin
                gain, offset = float(y.mean() / max(peaks[0], 1e-9)), 0.0
            self.brow_gain[c], self.brow_offset[c] = float(gain), float(offset)
        self.brows_fitted = True

    # -- the condition interface ---------------------------------------------------------------
    def fit(self, features: SpeechFeatures, ground_truth: MotionTrack | None
            ) -> SpeechDrivenCondition:
        """Fit the head ARX model and the eyebrow gains on the ground truth (if it has them)."""
        if ground_truth is None:
            return self
        gt = align_to_features(ground_truth, features)
        if any(c in gt.channels and np.std(gt[c]) > 0 for c in HEAD):
            self.head = HeadPoseArx.fit(features, gt, **self.order)
            self.head_note = "head ARX model fitted on the ground truth of this recording"
        self._fit_brows(features, gt)
        return self

    def _head_model(self) -> HeadPoseArx:
        if self.head is None:
            path = Path(self.model_path) if self.model_path else DEFAULT_MODEL_PATH
            self.head = HeadPoseArx.load(path)
            origin = self.head.provenance.get("fitted_on", "unknown data")
            self.head_note = (f"head ARX model read from {path.name}" if self.model_path else
                              f"no ground truth to fit: used the shipped default head model "
                              f"{path.name} (fitted on {origin})")
        return self.head

    def generate(self, features: SpeechFeatures, *, seed: int = 0,
                 ground_truth: MotionTrack | None = None) -> MotionTrack:
        track = self.base_track(features, ground_truth)
        brows, brow_info = self.eyebrows(features)
        head = self._head_model().generate(features)
        meta = dict(track.metadata, eyebrows=brow_info, head_model=self.head_note)
        return track.with_channels({**brows, **head}).replace(metadata=meta)

    def describe(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "eyes": self.eyes, "f0_threshold": self.f0_threshold,
            "intensity_threshold": self.intensity_threshold, "min_hold_s": self.min_hold_s,
            "release_frames": self.release_frames, "eyebrow_gain": self.brow_gain,
            "eyebrow_offset": self.brow_offset, "eyebrows_fitted": self.brows_fitted,
            "arx_order": self.order, "head_model": self.head_note,
        }
        if self.head is not None:
            d["head_model_info"] = {**self.head.provenance, **self.head.arx.info}
        return d
