"""What a generation hands back: the tracks, the speech features and ``summary.json``.

:func:`app.stimuli.generate.generate_conditions` returns a :class:`GenerationResult`;
:func:`generation_summary` writes down what went into it, so that a study can be traced to its
inputs and an experimenter can look at the conditions before running people: the recording
(the F0 and intensity of thesis sec. 4.3.4.1, and the speaker's pitch range), the ground truth
and whether it is synthetic or captured (:func:`capture_note`), and per condition its model,
parameters and objective measures (:mod:`app.stimuli.measures`: the head kinematics of Le, Ma
& Deng 2012 and the correlations with the speech). :func:`jsonable` turns it into plain JSON
types.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app import __version__
from app.stimuli.conditions import DISPLAY_NAMES
from app.stimuli.measures import measure_track
from app.stimuli.meshes.summary import mesh_entries
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


@dataclass(eq=False)
class GenerationResult:
    """The tracks by condition name, the speech features and a JSON-able summary."""

    tracks: dict[str, MotionTrack]
    features: SpeechFeatures
    summary: dict[str, Any] = field(default_factory=dict)


def generation_summary(
    audio_path: str | Path,
    features: SpeechFeatures,
    gt: MotionTrack | None,
    gt_aligned: MotionTrack | None,
    tracks: dict[str, MotionTrack],
    described: dict[str, Any],
    factors: dict[str, Any] | None,
    seed: int,
    eyes: str,
) -> dict[str, Any]:
    """The summary of one generation, before :func:`jsonable`: the speech, the ground truth,
    every condition's parameters, channels and objective measures
    (:func:`app.stimuli.measures.measure_track`, with the mesh measures of
    :mod:`app.stimuli.meshes.summary`), and notes for the experimenter."""
    notes: list[str] = []
    gt_info: dict[str, Any] | None = None
    if gt is not None:
        synthetic = "synthetic" in f"{gt.source} {gt.speaker} {gt.name}".lower()
        gt_info = {
            "source": gt.source,
            "speaker": gt.speaker,
            "fps": gt.fps,
            "frames": gt.n_frames,
            "synthetic": synthetic,
        }
        if synthetic:
            notes.append(
                "the ground truth is SYNTHETIC (facepair's reference speaker), not captured motion"
            )
        capture = gt.metadata.get("capture")
        if capture:
            gt_info["capture"] = capture
            notes.append(capture_note(gt.source, capture))
    conds: dict[str, Any] = {}
    mesh_info, mesh_measures, mesh_notes = mesh_entries(tracks, gt_aligned, features)
    notes += mesh_notes
    for name, track in tracks.items():
        entry: dict[str, Any] = {
            "display_name": DISPLAY_NAMES.get(name, name),
            "file": f"{name}.fap",
            "source": track.source,
            "frames": track.n_frames,
            "channels": list(track.channels),
            "parameters": described.get(name, {}),
            "measures": measure_track(track, features, gt_aligned),
        }
        if name in mesh_info:
            entry["mesh"] = mesh_info[name]
        if name in mesh_measures:
            entry["measures"]["mesh"] = mesh_measures[name]
        for key in (
            "model",
            "head_model",
            "head_mean",
            "eyebrows",
            "amplitudes",
            "carried_from_ground_truth",
            "eyes",
        ):
            if key in track.metadata:
                entry[key] = track.metadata[key]
        if track.metadata.get("head_model"):
            notes.append(f"{name}: {track.metadata['head_model']}")
        warning = track.metadata.get("eyebrows", {}).get("warning")
        if warning:
            notes.append(f"{name}: {warning}")
        conds[name] = entry
    return {
        "generator": f"facepair {__version__}",
        "audio": str(audio_path),
        "seed": seed,
        "speech": _speech_summary(features),
        "ground_truth": gt_info,
        "eyes": eyes,
        "normalized": factors is not None,
        "normalization": factors,
        "conditions": conds,
        "notes": notes,
    }


def _speech_summary(features: SpeechFeatures) -> dict[str, Any]:
    """The recording as the features saw it: F0 range, voicing and intensity."""
    voiced = features.f0[features.voiced]
    return {
        **features.metadata,
        "fps": features.fps,
        "frames": features.n_frames,
        "voiced_fraction": float(features.voiced.mean()) if features.n_frames else 0.0,
        "f0_hz": {
            "median": float(np.median(voiced)) if len(voiced) else None,
            "min": float(voiced.min()) if len(voiced) else None,
            "max": float(voiced.max()) if len(voiced) else None,
        },
        "intensity_db": {
            "min": float(features.intensity.min()),
            "median": float(np.median(features.intensity)),
            "max": float(features.intensity.max()),
        },
    }


def capture_note(source: str, capture: Mapping[str, Any], what: str = "ground truth") -> str:
    """One line on an imported ground truth (or another imported track, ``what``): lost
    samples, filled frames, FAPs absent from the file and the importer's warnings."""
    note = (
        f"{what} imported from {source}: {capture['samples']} samples at "
        f"{capture['capture_fps']:g} fps, {capture['invalid_samples']} lost, "
        f"{capture['filled_frames']} frames filled by interpolation"
    )
    missing = sorted({f for faps in capture.get("missing", {}).values() for f in faps})
    if missing:
        note += f"; FAPs {', '.join(map(str, missing))} absent from the file"
    warnings = [str(w) for w in capture.get("warnings", ()) or ()]
    if warnings:
        note += "; " + "; ".join(warnings)
    return note


def jsonable(x: Any) -> Any:
    """Plain JSON types: numpy scalars to Python, non-finite floats to None, keys to str."""
    if isinstance(x, Mapping):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if np.isfinite(x) else None
    if isinstance(x, Path):
        return str(x)
    return x
