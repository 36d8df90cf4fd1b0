"""From a speech recording (and ground truth) to the motion tracks of each condition.

The pipeline of thesis sec. 4.3: speech features per video frame (:mod:`app.stimuli.speech`);
each condition fitted on the ground truth where it learns from it and generated from the speech;
optionally normalised to the reference condition (sec. 5.3); objective measures of every track
(:mod:`app.stimuli.measures`). :func:`write_outputs` writes ``<condition>.fap`` per condition
and ``summary.json``.

Example
-------
>>> result = generate_conditions("data/demo/speech.wav", conditions=["none", "random"])
>>> sorted(result.tracks), result.tracks["random"].n_frames
(['none', 'random'], 120)
"""

from __future__ import annotations

import inspect
import json
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.conditions import DISPLAY_NAMES, condition_class, make_condition
from app.stimuli.conditions.ground_truth import align_to_features
from app.stimuli.features import SpeechFeatures
from app.stimuli.io import load_track, save_track
from app.stimuli.measures import measure_track
from app.stimuli.normalize import normalize_tracks
from app.stimuli.speech import extract_features
from app.stimuli.track import MotionTrack

DEFAULT_CONDITIONS = ("none", "random", "speech_driven", "ground_truth")


@dataclass(eq=False)
class GenerationResult:
    """The tracks by condition name, the speech features and a JSON-able summary."""

    tracks: dict[str, MotionTrack]
    features: SpeechFeatures
    summary: dict[str, Any] = field(default_factory=dict)


def parse_conditions(conditions: str | Iterable[str]) -> list[str]:
    """``"none,random"`` or a list -> validated, de-duplicated names in the given order."""
    names = conditions.split(",") if isinstance(conditions, str) else list(conditions)
    names = [n.strip() for n in names if n.strip()]
    if not names:
        raise InputError("no conditions given", field="conditions")
    for n in names:
        condition_class(n)  # unknown or unavailable: one clear line now, not halfway through
    return list(dict.fromkeys(names))


def generate_conditions(
    audio_path: str | Path, *, conditions: str | Iterable[str] = DEFAULT_CONDITIONS,
    ground_truth: str | Path | MotionTrack | None = None, fps: float = 30.0, seed: int = 0,
    normalize: bool = False, model_path: str | Path | None = None,
    progress: Callable[[int, int], None] | None = None, pitch_floor: float = 75.0,
    pitch_ceiling: float = 600.0,
    condition_params: Mapping[str, Mapping[str, Any]] | None = None,
) -> GenerationResult:
    """Generate the tracks of ``conditions`` for one recording.

    ``ground_truth`` is a track or a .fap/.csv path (``None``: the conditions that need it
    refuse, the others do without). ``model_path`` is a fitted head model for the conditions
    that take one (``speech_driven``), used instead of fitting. ``condition_params`` gives
    extra parameters per condition name. ``progress(done, total)`` is called after each step.
    """
    names = parse_conditions(conditions)
    if ground_truth is None and "ground_truth" in names:
        raise InputError("the ground_truth condition needs --ground-truth FILE",
                         field="conditions")
    if normalize and ground_truth is None:
        raise InputError("--normalize needs a reference: give --ground-truth",
                         field="normalize")
    params = {k: dict(v) for k, v in (condition_params or {}).items()}
    total = len(names) + 2 + int(normalize)
    done = 0

    def step() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total)

    features = extract_features(audio_path, fps, pitch_floor=pitch_floor,
                                pitch_ceiling=pitch_ceiling)
    gt_track = _load_ground_truth(ground_truth, fps)
    gt_aligned = align_to_features(gt_track, features) if gt_track is not None else None
    step()

    tracks: dict[str, MotionTrack] = {}
    described: dict[str, Any] = {}
    for name in names:
        kw = dict(params.get(name, {}))
        if model_path is not None and "model_path" in inspect.signature(
                condition_class(name)).parameters:
            kw.setdefault("model_path", str(model_path))
        cond = make_condition(name, **kw)
        if gt_track is not None:
            cond.fit(features, gt_track)
        track = cond.generate(features, seed=seed, ground_truth=gt_track)
        track.metadata.update(seed=seed, audio=str(audio_path))
        tracks[name] = track
        described[name] = cond.describe() if hasattr(cond, "describe") else {}
        step()

    factors = None
    if normalize:
        if "ground_truth" in tracks:
            reference: str | MotionTrack = "ground_truth"
        else:
            assert gt_aligned is not None  # checked on entry
            reference = gt_aligned
        tracks, factors = normalize_tracks(tracks, reference)
        step()

    summary = _summary(audio_path, features, gt_track, gt_aligned, tracks, described, factors,
                       seed)
    step()
    return GenerationResult(tracks, features, _jsonable(summary))


def _load_ground_truth(ground_truth: str | Path | MotionTrack | None, fps: float
                       ) -> MotionTrack | None:
    if ground_truth is None or isinstance(ground_truth, MotionTrack):
        return ground_truth
    if not Path(ground_truth).is_file():
        raise InputError("no such ground-truth file", path=ground_truth)
    return load_track(ground_truth, fps=fps)


def _speech_summary(features: SpeechFeatures) -> dict[str, Any]:
    voiced = features.f0[features.voiced]
    return {**features.metadata, "fps": features.fps, "frames": features.n_frames,
            "voiced_fraction": float(features.voiced.mean()) if features.n_frames else 0.0,
            "f0_hz": {"median": float(np.median(voiced)) if len(voiced) else None,
                      "min": float(voiced.min()) if len(voiced) else None,
                      "max": float(voiced.max()) if len(voiced) else None},
            "intensity_db": {"min": float(features.intensity.min()),
                             "median": float(np.median(features.intensity)),
                             "max": float(features.intensity.max())}}


def _summary(audio_path: str | Path, features: SpeechFeatures, gt: MotionTrack | None,
             gt_aligned: MotionTrack | None, tracks: dict[str, MotionTrack],
             described: dict[str, Any], factors: dict[str, Any] | None, seed: int
             ) -> dict[str, Any]:
    from app import __version__

    notes: list[str] = []
    gt_info: dict[str, Any] | None = None
    if gt is not None:
        synthetic = "synthetic" in f"{gt.source} {gt.speaker} {gt.name}".lower()
        gt_info = {"source": gt.source, "speaker": gt.speaker, "fps": gt.fps,
                   "frames": gt.n_frames, "synthetic": synthetic}
        if synthetic:
            notes.append("the ground truth is SYNTHETIC (facepair's reference speaker), "
                         "not captured motion")
    conds: dict[str, Any] = {}
    for name, track in tracks.items():
        entry: dict[str, Any] = {
            "display_name": DISPLAY_NAMES.get(name, name), "file": f"{name}.fap",
            "source": track.source, "frames": track.n_frames, "channels": list(track.channels),
            "parameters": described.get(name, {}),
            "measures": measure_track(track, features, gt_aligned),
        }
        for key in ("head_model", "eyebrows", "amplitudes", "carried_from_ground_truth"):
            if key in track.metadata:
                entry[key] = track.metadata[key]
        if track.metadata.get("head_model"):
            notes.append(f"{name}: {track.metadata['head_model']}")
        warning = track.metadata.get("eyebrows", {}).get("warning")
        if warning:
            notes.append(f"{name}: {warning}")
        conds[name] = entry
    return {"generator": f"facepair {__version__}", "audio": str(audio_path), "seed": seed,
            "speech": _speech_summary(features), "ground_truth": gt_info,
            "normalized": factors is not None, "normalization": factors,
            "conditions": conds, "notes": notes}


def _jsonable(x: Any) -> Any:
    """Plain JSON types: numpy scalars to Python, non-finite floats to None, keys to str."""
    if isinstance(x, Mapping):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if np.isfinite(x) else None
    if isinstance(x, Path):
        return str(x)
    return x


def write_outputs(result: GenerationResult, out_dir: str | Path, *, plot: bool = True,
                  greta: bool = False) -> list[Path]:
    """Write ``<condition>.fap`` per condition, ``summary.json`` and (``plot``) ``summary.png``.

    The tracks are in Xface's .fap dialect, or Greta's with ``greta``.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the output folder: {exc.strerror}", path=out) from None
    written = []
    for name, track in result.tracks.items():
        path = out / f"{name}.fap"
        save_track(track, path, greta=greta)
        written.append(path)
    summary_path = out / "summary.json"
    summary_path.write_text(json.dumps(result.summary, indent=1) + "\n", encoding="utf-8")
    written.append(summary_path)
    if plot:
        from app.stimuli.plot import plot_conditions

        written.append(plot_conditions(result, out / "summary.png"))
    return written
