"""From a speech recording (and ground truth) to the motion tracks of each condition.

The pipeline of thesis sec. 4.3: speech features per video frame (:mod:`app.stimuli.speech`);
each condition fitted on the ground truth where it learns from it and generated from the speech;
optionally normalised to the reference condition (sec. 5.3); objective measures of every track
(:mod:`app.stimuli.measures`) in the generation's summary (:mod:`app.stimuli.summary`).
:func:`write_outputs` writes ``<condition>.fap`` per condition, ``summary.json`` and its
picture (:mod:`app.stimuli.plot`).

Example
-------
>>> result = generate_conditions("app/data/demo/speech.wav", conditions=["none", "random"])
>>> sorted(result.tracks), result.tracks["random"].n_frames
(['none', 'random'], 120)
"""

from __future__ import annotations

import inspect
import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from app.errors import InputError
from app.stimuli.conditions import IMPORTED, condition_class, make_condition
from app.stimuli.conditions.base import ConditionModel
from app.stimuli.conditions.imported import ImportedCondition
from app.stimuli.eyes import DEFAULT_EYES, check_eyes
from app.stimuli.io import load_track, save_track
from app.stimuli.lengths import length_note
from app.stimuli.meshes.fairness import DEFAULT_MESH_EYES, check_mesh_eyes
from app.stimuli.normalize import normalize_tracks
from app.stimuli.plot import plot_conditions
from app.stimuli.posture import DEFAULT_POSTURE, check_posture
from app.stimuli.progress import Progress, progress_steps
from app.stimuli.shared import (
    DEFAULT_BROWS,
    DEFAULT_LIPS,
    check_brows,
    check_lips,
)
from app.stimuli.speech import SpeechFeatures, extract_features
from app.stimuli.summary import GenerationResult, capture_note, generation_summary, jsonable
from app.stimuli.track import MotionTrack, align_to_features
from app.stimuli.untested import share_untested

DEFAULT_CONDITIONS = ("none", "random", "speech_driven", "ground_truth")


#: One condition of a generation: the registry model and its parameters.
ConditionRequest = tuple[str, dict[str, Any]]


def parse_conditions(
    conditions: str | Iterable[str] | Mapping[str, Any],
) -> dict[str, ConditionRequest]:
    """Conditions as ``name -> (model, params)``, validated, in the given order.

    Accepts ``"none,random"``, a list of names (each name is its model), or a mapping from
    name to a model name, to its parameters, or to ``{"model": model, **params}`` (a study
    file's ``[[conditions]]``, where a condition called ``calm`` may use the model ``random``);
    ``{"track": path}`` is a condition imported from a file
    (:mod:`app.stimuli.conditions.imported`).
    """
    if isinstance(conditions, Mapping):
        items = list(conditions.items())
    else:
        names = conditions.split(",") if isinstance(conditions, str) else list(conditions)
        items = [(n.strip(), None) for n in names if n.strip()]
    if not items:
        raise InputError("no conditions given", field="conditions")
    out: dict[str, ConditionRequest] = {}
    for name, spec in items:
        if isinstance(spec, str):
            model, params = spec, {}
        elif isinstance(spec, Mapping):
            params = dict(spec)
            model = str(params.pop("model", None) or (IMPORTED if "track" in params else name))
        elif spec is None:
            model, params = name, {}
        elif isinstance(spec, tuple) and len(spec) == 2 and isinstance(spec[1], Mapping):
            model, params = str(spec[0]), dict(spec[1])  # already parsed
        else:
            raise InputError(
                f"condition {name!r}: expected a model name or a table of settings",
                field="conditions",
            )
        condition_class(model)  # unknown or unavailable: one clear line now, not halfway
        out.setdefault(name, (model, params))
    return out


def generate_conditions(
    audio_path: str | Path,
    *,
    conditions: str | Iterable[str] | Mapping[str, Any] = DEFAULT_CONDITIONS,
    ground_truth: str | Path | MotionTrack | None = None,
    fps: float = 30.0,
    seed: int = 0,
    normalize: bool = False,
    eyes: str = DEFAULT_EYES,
    models: Mapping[str, str | Path] | None = None,
    progress: Progress | None = None,
    pitch_floor: float | None = None,
    pitch_ceiling: float | None = None,
    condition_params: Mapping[str, Mapping[str, Any]] | None = None,
    posture: str = DEFAULT_POSTURE,
    lips: str = DEFAULT_LIPS,
    pad: bool = False,
    brows: str = DEFAULT_BROWS,
    meshes: Mapping[str, Any] | None = None,
    mesh_eyes: str = DEFAULT_MESH_EYES,
) -> GenerationResult:
    """Generate the tracks of ``conditions`` for one recording.

    ``conditions`` maps each condition name to its model and parameters (see
    :func:`parse_conditions`); ``condition_params`` adds parameters by name. ``ground_truth``
    is a track or a .fap/.csv path (``None``: the conditions that need it refuse, the others
    do without). ``models`` gives a fitted model file per condition name, used instead of
    fitting. What the study does not test is then made the same in every condition, imported
    ones included (:mod:`app.stimuli.shared`): ``eyes`` sets gaze and eyelids
    (:mod:`app.stimuli.eyes`; ``"own"`` keeps each condition's); ``posture``: ``"shared"``
    gives every condition the ground truth's rest head pose, ``"per_condition"`` keeps each
    condition's own, as in the thesis' experiment 1 (:mod:`app.stimuli.posture`); ``lips``:
    ``"shared"`` gives every condition the same jaw, lips and rest of the lower face (under
    the mouth mosaic), ``"own"`` keeps each condition's (a study that compares lip motion);
    ``brows``: ``"own"`` keeps each condition's eyebrows, ``"none"`` gives none to any,
    ``"rule"`` the thesis' speech-driven rule (sec. 4.3.4.1) to every condition, for a study
    of head and eyes alone.
    ``normalize`` scales and offsets every condition's head angles to the ground truth's mean
    and sd (thesis sec. 5.3). A ground truth or imported track longer or shorter than the
    speech by more than :data:`app.stimuli.lengths.LENGTH_TOLERANCE_S` is refused unless
    ``pad`` (:mod:`app.stimuli.lengths`). ``pitch_floor``/``pitch_ceiling``: the speaker's F0
    range, estimated from the recording where ``None``. ``progress(done, total)`` is called
    after each step.
    """
    requests = parse_conditions(conditions)
    _check_settings(
        requests, ground_truth, normalize, models, eyes, posture, lips, brows, mesh_eyes
    )
    step = progress_steps(progress, len(requests) + 3 + int(normalize))

    features = extract_features(
        audio_path, fps, pitch_floor=pitch_floor, pitch_ceiling=pitch_ceiling
    )
    notes: list[str] = []
    gt_track = _load_ground_truth(ground_truth, fps, meshes)
    gt_aligned = _align_ground_truth(gt_track, ground_truth, requests, features, pad, notes)
    step()

    tracks: dict[str, MotionTrack] = {}
    described: dict[str, Any] = {}
    for name, (model, params) in requests.items():
        kw = {**params, **dict((condition_params or {}).get(name, {}))}
        cond = _make_condition(name, model, kw, models, meshes)
        tracks[name] = _condition_track(
            cond, name, model, features, gt_track, gt_aligned, audio_path, seed, pad, notes
        )
        described[name] = {"model": model, **cond.describe()}
        step()

    tracks, shared = share_untested(
        tracks,
        [n for n, (m, _) in requests.items() if m == "live_gmm"],
        features,
        gt_aligned,
        eyes=eyes,
        posture=posture,
        lips=lips,
        brows=brows,
        mesh_eyes=mesh_eyes,
        seed=seed,
        notes=notes,
    )
    step()

    factors = None
    if normalize:
        assert gt_aligned is not None  # checked on entry
        gt_names = [n for n, (m, _) in requests.items() if m == "ground_truth"]
        tracks, factors = normalize_tracks(tracks, gt_names[0] if gt_names else gt_aligned)
        step()

    summary = generation_summary(
        audio_path, features, gt_track, gt_aligned, tracks, described, factors, seed, eyes
    )
    summary["notes"] = notes + summary["notes"]
    summary.update(shared)
    step()
    return GenerationResult(tracks, features, jsonable(summary))


def _check_settings(
    requests: Mapping[str, ConditionRequest],
    ground_truth: str | Path | MotionTrack | None,
    normalize: bool,
    models: Mapping[str, str | Path] | None,
    eyes: str,
    posture: str,
    lips: str,
    brows: str,
    mesh_eyes: str,
) -> None:
    """Refuse, before any work, the settings that cannot go together: a mode unknown, the
    ground truth missing where a condition or a setting needs it, a model file for a
    condition the generation does not have."""
    check_eyes(eyes)
    check_posture(posture)
    check_lips(lips)
    check_brows(brows)
    check_mesh_eyes(mesh_eyes)
    if ground_truth is None and any(m == "ground_truth" for m, _ in requests.values()):
        raise InputError("the ground_truth condition needs --ground-truth FILE", field="conditions")
    if normalize and ground_truth is None:
        raise InputError("--normalize needs a reference: give --ground-truth", field="normalize")
    if eyes == "ground_truth" and ground_truth is None:
        raise InputError("eyes = 'ground_truth' needs --ground-truth FILE", field="eyes")
    for name in models or {}:
        if name not in requests:
            raise InputError(
                f"a model is given for {name!r}, which is not among the "
                f"conditions ({', '.join(requests)})",
                field="model",
            )


def _align_ground_truth(
    gt_track: MotionTrack | None,
    ground_truth: str | Path | MotionTrack | None,
    requests: Mapping[str, ConditionRequest],
    features: SpeechFeatures,
    pad: bool,
    notes: list[str],
) -> MotionTrack | None:
    """The ground truth on the speech's frames (``None`` without one), its length checked
    against the speech's (:mod:`app.stimuli.lengths`; the ground_truth condition's ``offset``
    shifts it); a length padded or cut adds a line to ``notes``."""
    if gt_track is None:
        return None
    offsets = [p.get("offset", 0.0) for m, p in requests.values() if m == "ground_truth"]
    named = None if isinstance(ground_truth, MotionTrack) else Path(str(ground_truth)).name
    note = length_note(
        gt_track,
        features.n_frames,
        features.fps,
        what="ground truth",
        path=named,
        offset=float(offsets[0]) if offsets else 0.0,
        pad=pad,
    )
    notes += [f"{named}: {note}" if named else note] if note else []
    return align_to_features(gt_track, features)


def _make_condition(
    name: str,
    model: str,
    kw: dict[str, Any],
    models: Mapping[str, str | Path] | None,
    meshes: Mapping[str, Any] | None,
) -> ConditionModel:
    """The condition ``name`` of the registry's ``model`` with its parameters ``kw``, given
    its fitted model file (``models``) and, imported, the study's mesh settings."""
    if models and name in models:
        if "model_path" not in inspect.signature(condition_class(model)).parameters:
            raise InputError(f"condition {name!r} ({model}) takes no model file", field="model")
        kw["model_path"] = str(models[name])
    if model == IMPORTED and meshes:
        kw["mesh"] = {**dict(meshes), **dict(kw.get("mesh") or {})}
    return make_condition(model, **kw)


def _condition_track(
    cond: ConditionModel,
    name: str,
    model: str,
    features: SpeechFeatures,
    gt_track: MotionTrack | None,
    gt_aligned: MotionTrack | None,
    audio_path: str | Path,
    seed: int,
    pad: bool,
    notes: list[str],
) -> MotionTrack:
    """One condition's track: an imported one read and its length checked (a note on its
    length or its capture added to ``notes``), any other fitted on the aligned ground truth
    where there is one; then generated from the speech."""
    if isinstance(cond, ImportedCondition):
        source = cond.source_track(features.fps)
        note = length_note(
            source,
            features.n_frames,
            features.fps,
            what=f"condition {name}",
            path=cond.label,
            offset=cond.offset,
            pad=pad,
        )
        notes += [f"{cond.label}: {note}"] if note else []
        capture = source.metadata.get("capture")
        if isinstance(capture, Mapping) and {"samples", "capture_fps"} <= capture.keys():
            notes.append(capture_note(cond.label, capture, what=f"condition {name}"))
    elif gt_aligned is not None:
        cond.fit(features, gt_aligned)
    track = cond.generate(features, seed=seed, ground_truth=gt_track)
    track.metadata.update(seed=seed, audio=str(audio_path), model=model)
    return track


def _load_ground_truth(
    ground_truth: str | Path | MotionTrack | None,
    fps: float,
    meshes: Mapping[str, Any] | None = None,
) -> MotionTrack | None:
    if ground_truth is None or isinstance(ground_truth, MotionTrack):
        return ground_truth
    if not Path(ground_truth).is_file():
        raise InputError("no such ground-truth file", path=ground_truth)
    return load_track(ground_truth, fps=fps, mesh=meshes)


def write_outputs(
    result: GenerationResult, out_dir: str | Path, *, plot: bool = True, greta: bool = False
) -> list[Path]:
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
        written.append(plot_conditions(result, out / "summary.png"))
    return written
