"""What ``summary.json`` says of the mesh conditions of a clip, and their field metrics.

For every condition that is a mesh (:mod:`app.stimuli.meshes.source`), the summary's entry gets
``mesh``: the file, its topology, frame rate and units, what was inferred. When the clip's ground
truth is a vertex sequence too, every mesh condition of the same topology gets
``measures["mesh"]``: LVE and FDD (:mod:`app.stimuli.meshes.metrics`), on the frames of the
speech (both sequences read at the features' frame rate, each after its own alignment offset),
with the lip and upper-face vertices of the ground truth's region file, else found on the
ground truth (the lips from its motion that follows the speech's intensity, the upper face
above the middle of the nose: :mod:`app.stimuli.meshes.regions`), the same vertices for every
condition. These sit beside the head-motion measures every condition has
(:func:`app.stimuli.measures.measure_track`); the analysis reads them as objective measures,
never as part of the perceptual scale (:mod:`app.analysis.objective`).

Example
-------
>>> from app.stimuli.track import MotionTrack
>>> mesh_entries({"a": MotionTrack.zeros(30, 3)}, None, None)
({}, {}, [])
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from app.stimuli.meshes.metrics import field_measures
from app.stimuli.meshes.regions import find_lips, mouth_points_of, upper_face_band
from app.stimuli.meshes.sequence import MeshSequence, sample
from app.stimuli.meshes.source import mesh_of
from app.stimuli.meshes.vertexfile import UNITS
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


def _on_speech(track: MotionTrack, seq: MeshSequence, features: SpeechFeatures) -> np.ndarray:
    offset = float(track.metadata.get("offset_s", 0.0) or 0.0)
    return sample(seq, features.n_frames, features.fps, offset)


def mesh_entries(
    tracks: Mapping[str, MotionTrack],
    ground_truth: MotionTrack | None,
    features: SpeechFeatures | None,
) -> tuple[dict[str, dict[str, Any]], dict[str, dict[str, float]], list[str]]:
    """``(entries, measures, notes)``: per mesh condition its summary entry's ``mesh`` and
    (with a mesh ground truth) its ``measures["mesh"]``, and lines for the summary's notes."""
    entries: dict[str, dict[str, Any]] = {}
    meshes: dict[str, MeshSequence] = {}
    notes: list[str] = []
    for name, track in tracks.items():
        seq = mesh_of(track)
        if seq is None:
            continue
        meshes[name] = seq
        entries[name] = {
            "file": seq.label,
            "kind": seq.kind,
            "vertices": seq.n_vertices,
            "frames": seq.n_frames,
            "fps": seq.fps,
            "units": seq.units,
            "eyeballs": seq.eyeballs is not None,
            "notes": list(track.metadata.get("mesh_notes", seq.notes)),
        }
    truth = mesh_of(ground_truth) if ground_truth is not None else None
    if truth is None or features is None or not meshes:
        return entries, {}, notes
    assert ground_truth is not None
    gt_frames = _on_speech(ground_truth, truth, features)
    if truth.lips is not None:
        lips, lips_from = truth.lips, "the ground truth's region file"
    else:
        eyes = np.concatenate(truth.eyeballs) if truth.eyeballs is not None else None
        lips = find_lips(
            truth.template, gt_frames, features.intensity, exclude=eyes, name=truth.label
        ).lips
        lips_from = "found on the ground truth's motion that follows the speech"
    if truth.upper is not None:
        upper, upper_from = truth.upper, "the ground truth's region file"
    else:
        upper = upper_face_band(truth.template, mouth_points_of(truth.template, lips))
        upper_from = "above the middle of the nose on the ground truth's template"
    measures: dict[str, dict[str, float]] = {}
    scale = UNITS.get(truth.units, 1.0)
    for name, seq in meshes.items():
        if seq.n_vertices != truth.n_vertices:
            notes.append(
                f"{name}: no LVE or FDD: {seq.n_vertices} vertices, the ground truth "
                f"{truth.label} has {truth.n_vertices}"
            )
            continue
        measures[name] = field_measures(
            _on_speech(tracks[name], seq, features),
            gt_frames,
            truth.template,
            lips,
            upper,
            scale=scale,
        )
        entries[name]["field_metrics"] = {
            "ground_truth": truth.label,
            "frames": int(features.n_frames),
            "lip_vertices": int(len(lips)),
            "lips_from": lips_from,
            "upper_vertices": int(len(upper)),
            "upper_from": upper_from,
            "squared_units": f"{truth.units}^2",
        }
    return entries, measures, notes
