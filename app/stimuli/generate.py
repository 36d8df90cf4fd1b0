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
from app.stimuli.conditions.imported import ImportedCondition
from app.stimuli.eyes import DEFAULT_EYES, check_eyes, eye_channels
from app.stimuli.fap import EYEBROWS
from app.stimuli.io import load_track, save_track
from app.stimuli.lengths import length_note
from app.stimuli.meshes.fairness import DEFAULT_MESH_EYES, check_mesh_eyes, match_mesh_eyes
from app.stimuli.normalize import normalize_tracks
from app.stimuli.plot import plot_conditions
from app.stimuli.posture import DEFAULT_POSTURE, check_posture, rest_posture, share_posture
from app.stimuli.progress import Progress, progress_steps
from app.stimuli.shared import (
    DEFAULT_BROWS,
    DEFAULT_LIPS,
    EYE_GROUP,
    check_brows,
    check_lips,
    face_channels,
    moves,
    share_channels,
)
from app.stimuli.speech import SpeechFeatures, extract_features
from app.stimuli.summary import GenerationResult, capture_note, generation_summary, jsonable
from app.stimuli.track import MotionTrack, align_to_features

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
    step = progress_steps(progress, len(requests) + 3 + int(normalize))

    features = extract_features(
        audio_path, fps, pitch_floor=pitch_floor, pitch_ceiling=pitch_ceiling
    )
    notes: list[str] = []
    gt_track = _load_ground_truth(ground_truth, fps, meshes)
    gt_aligned = None
    if gt_track is not None:
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
        gt_aligned = align_to_features(gt_track, features)
    step()

    tracks: dict[str, MotionTrack] = {}
    described: dict[str, Any] = {}
    for name, (model, params) in requests.items():
        kw = {**params, **dict((condition_params or {}).get(name, {}))}
        if models and name in models:
            if "model_path" not in inspect.signature(condition_class(model)).parameters:
                raise InputError(f"condition {name!r} ({model}) takes no model file", field="model")
            kw["model_path"] = str(models[name])
        if model == IMPORTED and meshes:
            kw["mesh"] = {**dict(meshes), **dict(kw.get("mesh") or {})}
        cond = make_condition(model, **kw)
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
        tracks[name] = track
        described[name] = {"model": model, **cond.describe()}
        step()

    rest = rest_posture(gt_aligned) if posture == "shared" else None
    if rest is not None:
        tracks = share_posture(tracks, rest)

    tracks, eyes_from = _share_eyes(tracks, requests, eyes, features, gt_aligned, seed)
    tracks, mesh_eyes_note = match_mesh_eyes(tracks, mesh_eyes)
    notes += [mesh_eyes_note] if mesh_eyes_note else []
    face_cols, lips_from = face_channels(lips, tracks, gt_aligned)
    if face_cols is not None:
        tracks = share_channels(tracks, face_cols)
    elif len(tracks) > 1:
        notes.append(
            "lips = 'own': each condition keeps its own jaw and lip motion (for a study "
            "without the mouth mosaic that compares it)"
        )
    tracks, brows_from = _share_brows(tracks, requests, brows, features, notes)
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
    summary["eyes_from"] = eyes_from
    summary["lips"] = {"mode": lips, "from": lips_from}
    summary["brows"] = {"mode": brows, "from": brows_from}
    if mesh_eyes_note:
        summary["mesh_eyes"] = {"mode": mesh_eyes, "note": mesh_eyes_note}
    summary["posture"] = {
        "mode": posture,
        "rest_head_au": rest,
        "rest_from": None
        if rest is None
        else ("median of the ground truth" if gt_aligned is not None else "neutral"),
    }
    step()
    return GenerationResult(tracks, features, jsonable(summary))


def _share_brows(
    tracks: dict[str, MotionTrack],
    requests: Mapping[str, ConditionRequest],
    brows: str,
    features: SpeechFeatures,
    notes: list[str],
) -> tuple[dict[str, MotionTrack], str]:
    """Every track with the study's eyebrows (``brows``), and where they come from."""
    if brows == "own":
        still = [n for n, (m, _) in requests.items() if m == "live_gmm"]
        moving = [n for n, t in tracks.items() if moves(t, EYEBROWS)]
        if still and moving:
            notes.append(
                f"{', '.join(still)} (live_gmm) moves no eyebrow, as Le et al.'s model has "
                f"none, while {', '.join(moving)} do: their pairs differ in the brows too; "
                "brows = 'none' or 'rule' gives every condition the same"
            )
        return tracks, "each condition's own"
    if brows == "none":
        return share_channels(tracks, {}, EYEBROWS), "none (no eyebrow motion)"
    from app.stimuli.conditions.speech_driven import SpeechDrivenCondition

    cols, _ = SpeechDrivenCondition().eyebrows(features)
    return share_channels(tracks, cols, EYEBROWS), "the thesis' speech-driven rule"


def _share_eyes(
    tracks: dict[str, MotionTrack],
    requests: Mapping[str, ConditionRequest],
    eyes: str,
    features: SpeechFeatures,
    gt_aligned: MotionTrack | None,
    seed: int,
) -> tuple[dict[str, MotionTrack], str]:
    """Every track with the clip's eyes under ``eyes`` (:mod:`app.stimuli.eyes`), and where
    they come from; ``own`` checks that each condition has eyes of its own."""
    if eyes == "own":
        lacking = [n for n, t in tracks.items() if not moves(t, EYE_GROUP)]
        if lacking:
            named = ", ".join(
                f"{n} ({tracks[n].metadata['file']})" if "file" in tracks[n].metadata else n
                for n in lacking
            )
            raise InputError(
                f"eyes = 'own' keeps each condition's own eyes, but condition {named} "
                "carries no eye motion (FAPs 19-26 absent or 0): give it eye motion, or "
                "share generated eyes (eyes = 'generated')",
                field="eyes",
            )
        return tracks, "each condition's own"
    live = [n for n, (m, _) in requests.items() if m == "live_gmm"]
    if eyes == "generated" and live:  # the live model's own eyes, for every face alike
        cols = {c: tracks[live[0]].get(c) for c in EYE_GROUP if c in tracks[live[0]].channels}
        eyes_from = f"condition {live[0]} (live_gmm)"
    else:
        cols = eye_channels(eyes, features, gt_aligned, seed=seed)
        eyes_from = {"generated": "the shipped live model"}.get(eyes, eyes)
    shared = share_channels(tracks, cols, EYE_GROUP)
    return {
        n: t.replace(metadata={**t.metadata, "eyes": eyes}) for n, t in shared.items()
    }, eyes_from


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
