"""The trained live head-and-eye model and its training from speech + ground truth.

:func:`train_live_model` fits the three modules of Le, Ma & Deng 2012 in the order the paper
chains them (sec. 3): head (sec. 5) on (head pose, pitch, loudness), with the speech-driven pose
read from its angle mixtures and the variation around it (:mod:`app.stimuli.live.expectation`);
gaze (sec. 6) on (ground-truth head pose, loudness) -> gaze; eyelids (sec. 7) on gaze -> lids
and the blinks. Pitch and loudness are standardised per speaker, causally, per take
(:class:`app.stimuli.live.inputs.SpeakerNorm`), as the generator does. The model's file is
:mod:`app.stimuli.live.modelfile`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.fap import DEG_PER_AU, EYELIDS, GAZE, HEAD_PITCH, HEAD_ROLL, HEAD_YAW
from app.stimuli.live.expectation import SpeechPose, fit_speech_pose
from app.stimuli.live.eyelids import EyelidModel, fit_eyelid_model
from app.stimuli.live.gaze import FixationModel, GazeModel, fit_fixation_model, fit_gaze_model
from app.stimuli.live.head import HeadModel, fit_head_model
from app.stimuli.live.inputs import (
    SMOOTH_S,
    SPEAKER_NORM_S,
    SpeechScale,
    smoothed_inputs,
    speaker_normalised,
    talking_mode,
)
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack

#: How the generator reads the head model: the GMMs' expectation plus variation (the default,
#: :mod:`app.stimuli.live.expectation`) or the earlier per-frame Langevin draw of eq. 3.
SYNTHESES = ("expectation", "langevin")


@dataclass(frozen=True)
class LiveModel:
    """Speech scaling, the three modules, and the training summary."""

    fps: float
    scale: SpeechScale
    head: HeadModel
    gaze: GazeModel
    eyelids: EyelidModel
    fixations: FixationModel
    summary: dict[str, Any] = field(default_factory=dict)
    talk_window_s: float = 0.5
    pose: SpeechPose | None = None  # alignment and variation; None: Langevin synthesis only
    speaker_norm_s: float = 0.0  # per-speaker normalisation time constant, s (0: none)


def head_angles(track: MotionTrack) -> np.ndarray:
    """(n, 3) head (yaw, pitch, roll) in degrees from FAPs 49, 48, 50 (FAP signs kept)."""
    return (
        np.column_stack([track.get(HEAD_YAW), track.get(HEAD_PITCH), track.get(HEAD_ROLL)])
        * DEG_PER_AU
    )


def gaze_angles(track: MotionTrack) -> np.ndarray:
    """(n, 2) gaze (yaw, pitch) in degrees: the two eyes' FAPs 23/24 and 25/26 averaged."""
    g = [track.get(f) for f in GAZE]
    return np.column_stack([(g[0] + g[1]) / 2, (g[2] + g[3]) / 2]) * DEG_PER_AU


def train_live_model(
    features: SpeechFeatures | Sequence[SpeechFeatures],
    ground_truth: MotionTrack | Sequence[MotionTrack],
    *,
    n_components: int = 10,
    seed: int = 0,
    n_iter: int = 17,
    head_weights: Sequence[float] | None = None,
    speaker_norm_s: float | None = SPEAKER_NORM_S,
    progress: Callable[[], None] | None = None,
) -> LiveModel:
    """Fit the live model to speech features and a ground-truth track, or to several takes
    (lists of the same length, concatenated for fitting; nothing temporal spans two takes).
    Each ground truth is resampled to its features' frame rate and length. ``progress`` is
    called once per fitted part (12 calls). ``head_weights``: the exponents of eq. 4's five
    likelihoods (default :data:`app.stimuli.live.head.DEFAULT_WEIGHTS`). ``speaker_norm_s``:
    time constant of the per-speaker normalisation (None or 0: the training statistics for
    every speaker, as before version 3).

    Raises :class:`InputError` if the ground truth has no head motion or too few frames.
    """
    feats, gts, name = _checked_takes(features, ground_truth)
    fps = float(feats[0].fps)
    lengths = [f.n_frames for f in feats]
    starts = list(np.cumsum([0] + lengths[:-1]))
    n = sum(lengths)
    speech = _speech_inputs(feats, fps, speaker_norm_s)
    angles = np.concatenate([head_angles(gt) for gt in gts])
    if not np.any(angles.std(axis=0) > 1e-9):
        raise InputError(
            "the ground truth's head does not move (FAPs 48-50 constant)",
            path=name,
            field="channels",
        )
    head = fit_head_model(
        angles,
        speech.pz,
        speech.lz,
        fps,
        starts=starts,
        n_components=n_components,
        seed=seed,
        n_iter=n_iter,
        weights=head_weights,
        progress=progress,
    )
    pose, pose_summary = fit_speech_pose(head, angles, speech.pz, speech.lz, fps, starts)
    gaze_gt = np.concatenate([gaze_angles(gt) for gt in gts])
    h = np.column_stack([angles, speech.lz])
    gaze = fit_gaze_model(h, gaze_gt, starts)
    threshold_db = speech.scale.threshold_db
    talking = np.concatenate([talking_mode(lo, threshold_db, fps) for _, lo in speech.contours])
    ends = starts[1:] + [n]
    predicted = np.concatenate([gaze.run(h[a:b]) for a, b in zip(starts, ends, strict=True)])
    fixations, fix_summary = fit_fixation_model(gaze_gt, predicted, talking, fps, starts)
    if progress:
        progress()
    has_lids = any(c in gt.channels for gt in gts for c in EYELIDS)
    lids = (
        np.concatenate([gt.dense()[:, [c - 1 for c in EYELIDS]] for gt in gts])
        if has_lids
        else None
    )
    eyelids, lid_summary = fit_eyelid_model(gaze_gt, lids, talking, fps, starts)
    if progress:
        progress()
    summary = {
        **_training_data(feats, gts, speech, talking),
        "n_components": n_components,
        "seed": seed,
        "input_smoothing_s": SMOOTH_S,
        "speaker_normalisation_s": speech.norm_s,
        "head_weights": [float(w) for w in head.weights],
        "head_expectation": pose_summary,
        "gaze_enabled": gaze.enabled,
        "gaze_canonical_correlations": [float(c) for c in gaze.correlations],
        "eyelids": lid_summary,
        "fixations": fix_summary,
    }
    return LiveModel(
        fps, speech.scale, head, gaze, eyelids, fixations, summary, 0.5, pose, speech.norm_s
    )


def _checked_takes(
    features: SpeechFeatures | Sequence[SpeechFeatures],
    ground_truth: MotionTrack | Sequence[MotionTrack],
) -> tuple[list[SpeechFeatures], list[MotionTrack], str | None]:
    """The takes' speech features, their ground truths resampled to the features' frame rate
    and length, and the first ground truth's name (for errors); refuses takes that differ in
    number or frame rate, a ground truth without head motion and fewer than 100 frames."""
    feats = [features] if isinstance(features, SpeechFeatures) else list(features)
    truths = [ground_truth] if isinstance(ground_truth, MotionTrack) else list(ground_truth)
    if len(feats) != len(truths) or not feats:
        raise InputError(
            f"{len(feats)} speech takes but {len(truths)} ground truths", field="ground_truth"
        )
    fps = float(feats[0].fps)
    gts = []
    for f, gt in zip(feats, truths, strict=True):
        if f.fps != fps:
            raise InputError(f"takes differ in frame rate ({f.fps:g} vs {fps:g} fps)", field="fps")
        if not any(c in gt.channels for c in (HEAD_PITCH, HEAD_YAW, HEAD_ROLL)):
            raise InputError(
                "the ground truth has no head motion (FAPs 48-50)",
                path=gt.name or None,
                field="channels",
            )
        gts.append((gt if gt.fps == fps else gt.resample(fps)).fit_length(f.n_frames))
    n = sum(f.n_frames for f in feats)
    if n < 100:
        raise InputError(
            f"{n} frames is too little to train on (need at least 100)", path=truths[0].name or None
        )
    return feats, gts, truths[0].name or None


@dataclass(frozen=True)
class _SpeechInputs:
    """The model's speech inputs over every take, concatenated: pitch (semitones) and
    loudness (dB) smoothed per take, their scale, and both standardised per speaker."""

    contours: list[tuple[np.ndarray, np.ndarray]]  # per take: (pitch st, loudness dB)
    pitch_st: np.ndarray
    scale: SpeechScale
    norm_s: float  # per-speaker normalisation time constant, s (0: none)
    pz: np.ndarray
    lz: np.ndarray


def _speech_inputs(
    feats: list[SpeechFeatures], fps: float, speaker_norm_s: float | None
) -> _SpeechInputs:
    """Pitch and loudness of every take, smoothed causally and standardised per speaker
    take by take (:mod:`app.stimuli.live.inputs`), as the generator reads them."""
    contours = [smoothed_inputs(f.f0, f.intensity, fps) for f in feats]  # per take: causal
    pitch_st = np.concatenate([p for p, _ in contours])
    loud_db = np.concatenate([lo for _, lo in contours])
    scale = SpeechScale.fit_contours(pitch_st, loud_db)
    norm_s = float(speaker_norm_s or 0.0)
    normed = [speaker_normalised(p, lo, scale, fps, norm_s) for p, lo in contours]  # per take
    pz = np.concatenate([p for p, _ in normed])
    lz = np.concatenate([lo for _, lo in normed])
    return _SpeechInputs(contours, pitch_st, scale, norm_s, pz, lz)


def _training_data(
    feats: list[SpeechFeatures],
    gts: list[MotionTrack],
    speech: _SpeechInputs,
    talking: np.ndarray,
) -> dict[str, Any]:
    """The summary's account of what the model was trained on: frames, takes, channels,
    voiced and talking frames, and where the ground truths and the audio came from."""
    n = sum(f.n_frames for f in feats)
    fps = float(feats[0].fps)
    return {
        "frames": n,
        "fps": fps,
        "duration_s": n / fps,
        "takes": len(feats),
        "channels": sorted({c for gt in gts for c in gt.channels}),
        "voiced_frames": int(np.isfinite(speech.pitch_st).sum()),
        "talking_frames": int(talking.sum()),
        "ground_truth": [
            {
                "name": gt.name,
                "source": gt.source,
                "speaker": gt.speaker,
                "seed": gt.metadata.get("seed"),
            }
            for gt in gts
        ],
        "audio": sorted({str(f.metadata.get("audio", "")) for f in feats}),
    }
