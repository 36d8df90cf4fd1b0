"""The trained live head-and-eye model: training from speech + ground truth, and its file.

:func:`train_live_model` fits the three modules of Le, Ma & Deng 2012 in the order the paper
chains them (sec. 3): head (sec. 5) on (head pose, pitch, loudness), with the speech-driven pose
read from its angle mixtures and the variation around it (:mod:`app.stimuli.live.expectation`);
gaze (sec. 6) on (ground-truth head pose, loudness) -> gaze; eyelids (sec. 7) on gaze -> lids
and the blinks. Pitch and loudness are standardised per speaker, causally, per take
(:class:`app.stimuli.live.inputs.SpeakerNorm`), as the generator does.

File format (``.npz``, read with ``allow_pickle=False``; see docs/reference/live.md): numeric arrays
named below plus ``meta``, a UTF-8 JSON document stored as a uint8 array, holding the format name
and version, the frame rate, the settings and the training summary (frames, fps, channels, ...).
"""

from __future__ import annotations

import json
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
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
from app.stimuli.live.mixture import Mixture, MixtureBank
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack

FORMAT = "facepair-live-gmm"
VERSION = 3
#: How the generator reads the head model: the GMMs' expectation plus variation (the default,
#: :mod:`app.stimuli.live.expectation`) or the earlier per-frame Langevin draw of eq. 3.
SYNTHESES = ("expectation", "langevin")
_MIX = ("weights", "means", "covariances")


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
    lengths = [f.n_frames for f in feats]
    starts = list(np.cumsum([0] + lengths[:-1]))
    n = sum(lengths)
    if n < 100:
        raise InputError(
            f"{n} frames is too little to train on (need at least 100)", path=truths[0].name or None
        )
    contours = [smoothed_inputs(f.f0, f.intensity, fps) for f in feats]  # per take: causal
    pitch_st = np.concatenate([p for p, _ in contours])
    loud_db = np.concatenate([lo for _, lo in contours])
    scale = SpeechScale.fit_contours(pitch_st, loud_db)
    norm_s = float(speaker_norm_s or 0.0)
    normed = [speaker_normalised(p, lo, scale, fps, norm_s) for p, lo in contours]  # per take
    pz = np.concatenate([p for p, _ in normed])
    lz = np.concatenate([lo for _, lo in normed])
    angles = np.concatenate([head_angles(gt) for gt in gts])
    if not np.any(angles.std(axis=0) > 1e-9):
        raise InputError(
            "the ground truth's head does not move (FAPs 48-50 constant)",
            path=truths[0].name or None,
            field="channels",
        )
    head = fit_head_model(
        angles,
        pz,
        lz,
        fps,
        starts=starts,
        n_components=n_components,
        seed=seed,
        n_iter=n_iter,
        weights=head_weights,
        progress=progress,
    )
    pose, pose_summary = fit_speech_pose(head, angles, pz, lz, fps, starts)
    gaze_gt = np.concatenate([gaze_angles(gt) for gt in gts])
    h = np.column_stack([angles, lz])
    gaze = fit_gaze_model(h, gaze_gt, starts)
    talking = np.concatenate([talking_mode(lo, scale.threshold_db, fps) for _, lo in contours])
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
        "frames": n,
        "fps": fps,
        "duration_s": n / fps,
        "takes": len(feats),
        "channels": sorted({c for gt in gts for c in gt.channels}),
        "voiced_frames": int(np.isfinite(pitch_st).sum()),
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
        "n_components": n_components,
        "seed": seed,
        "input_smoothing_s": SMOOTH_S,
        "speaker_normalisation_s": norm_s,
        "head_weights": [float(w) for w in head.weights],
        "head_expectation": pose_summary,
        "gaze_enabled": gaze.enabled,
        "gaze_canonical_correlations": [float(c) for c in gaze.correlations],
        "eyelids": lid_summary,
        "fixations": fix_summary,
    }
    return LiveModel(fps, scale, head, gaze, eyelids, fixations, summary, 0.5, pose, norm_s)


# -- file format ---------------------------------------------------------------------------------


def save_model(model: LiveModel, path: str | Path) -> Path:
    """Write ``model`` as an ``.npz`` file (no pickled objects)."""
    path = Path(path)
    arrays: dict[str, np.ndarray] = {"speech_scale": model.scale.to_array()}
    for bank_name, bank in (
        ("head_voiced", model.head.voiced),
        ("head_unvoiced", model.head.unvoiced),
    ):
        k = max(m.n_components for m in bank.mixtures)
        padded = [m.padded(k) for m in bank.mixtures]
        for attr in _MIX:
            arrays[f"{bank_name}_{attr}"] = np.stack([getattr(m, attr) for m in padded])
    h = model.head
    if model.pose is None:
        raise ValueError("a live model without its speech pose (alignment, variation) is not saved")
    arrays.update(
        head_kin_mean=h.kin_mean,
        head_kin_std=h.kin_std,
        head_step_std=h.step_std,
        head_weights=h.weights,
        head_expectation=model.pose.to_array(),
    )
    g = model.gaze
    for name in (
        "h_mean",
        "h_std",
        "phi_mean",
        "phi_std",
        "u",
        "ce_t",
        "a_t",
        "v_star",
        "e_mean",
        "e_std",
        "correlations",
    ):
        arrays[f"gaze_{name}"] = np.asarray(getattr(g, name))
    arrays.update(
        eyelid_cb=model.eyelids.cb,
        eyelid_blink=model.eyelids.blink,
        gaze_fixation_intervals=model.fixations.intervals,
        gaze_fixation_offsets=model.fixations.offsets,
    )
    meta = {
        "format": FORMAT,
        "version": VERSION,
        "fps": model.fps,
        "head": {
            "n_iter": h.n_iter,
            "proposal": h.proposal,
            "kinematic_order": ["yaw", "pitch", "roll", "velocity", "acceleration"],
        },
        "gaze": {"lambdas": list(g.lambdas), "enabled": g.enabled},
        "eyelids": {"top_share": model.eyelids.top_share, "shape_s": list(model.eyelids.shape)},
        "talk_window_s": model.talk_window_s,
        "speech": {"speaker_normalisation_s": model.speaker_norm_s},
        "training": model.summary,
    }
    arrays["meta"] = np.frombuffer(json.dumps(meta, indent=1).encode("utf-8"), dtype=np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)  # type: ignore[arg-type]
    return path


_SHAPES: dict[str, tuple[int | None, ...]] = {
    "speech_scale": (5,),
    "head_kin_mean": (5,),
    "head_kin_std": (5,),
    "head_step_std": (3,),
    "head_weights": (5,),
    "head_expectation": (3, 6),
    "head_voiced_weights": (5, None),
    "head_voiced_means": (5, None, 3),
    "head_voiced_covariances": (5, None, 3, 3),
    "head_unvoiced_weights": (5, None),
    "head_unvoiced_means": (5, None, 2),
    "head_unvoiced_covariances": (5, None, 2, 2),
    "gaze_h_mean": (4,),
    "gaze_h_std": (4,),
    "gaze_phi_mean": (4,),
    "gaze_phi_std": (4,),
    "gaze_u": (4, 2),
    "gaze_ce_t": (2, 2),
    "gaze_a_t": (2, 2),
    "gaze_v_star": (2, 2),
    "gaze_e_mean": (2,),
    "gaze_e_std": (2,),
    "gaze_correlations": (2,),
    "eyelid_cb": (3,),
    "eyelid_blink": (2, 2),
    "gaze_fixation_intervals": (2, 2),
    "gaze_fixation_offsets": (2, 4),
}


def _check_array(name: str, a: np.ndarray, path: Path) -> np.ndarray:
    want = _SHAPES[name]
    if a.ndim != len(want) or any(
        w is not None and w != s for w, s in zip(want, a.shape, strict=True)
    ):
        shape = "x".join("K" if w is None else str(w) for w in want)
        raise InputError(
            f"expected shape {shape}, got {'x'.join(map(str, a.shape))}", path=path, field=name
        )
    if a.dtype.kind not in "fi" or not np.all(np.isfinite(a)):
        raise InputError("expected finite numbers", path=path, field=name)
    return a.astype(np.float64)


def _mixtures(arrays: dict[str, np.ndarray], prefix: str, path: Path) -> MixtureBank:
    w, mu, cov = (arrays[f"{prefix}_{a}"] for a in _MIX)
    if not (w.shape[1] == mu.shape[1] == cov.shape[1]) or np.any(w < 0):
        raise InputError("mixture weights, means and covariances disagree", path=path, field=prefix)
    mixtures = []
    for g in range(5):
        eig = np.linalg.eigvalsh(cov[g])
        if np.any(eig <= 0) or not np.isclose(w[g].sum(), 1.0, atol=1e-6):
            raise InputError(
                f"mixture {g} is not a valid Gaussian mixture "
                "(weights must sum to 1, covariances be positive definite)",
                path=path,
                field=prefix,
            )
        mixtures.append(Mixture(w[g], mu[g], cov[g]))
    return MixtureBank.stack(mixtures)


def load_model(path: str | Path) -> LiveModel:
    """Read a model written by :func:`save_model`; any problem is one :class:`InputError`."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            npz = np.load(fh, allow_pickle=False)
            if not isinstance(npz, np.lib.npyio.NpzFile):
                raise InputError(
                    "not a live model file: a single array, not an .npz archive", path=path
                )
            with npz:
                raw = {k: npz[k] for k in npz.files}
    except FileNotFoundError:
        raise InputError("no such model file", path=path) from None
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise InputError(f"not a live model file (.npz): {exc}", path=path) from None
    if "meta" not in raw:
        raise InputError("not a live model file: no 'meta' entry", path=path)
    try:
        meta = json.loads(raw["meta"].tobytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"unreadable JSON: {exc}", path=path, field="meta") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise InputError(f"not a {FORMAT} model file", path=path, field="meta.format")
    if meta.get("version") != VERSION:
        raise InputError(
            f"model file version {meta.get('version')!r}, this program reads version {VERSION}",
            path=path,
            field="meta.version",
        )
    missing = sorted(set(_SHAPES) - set(raw))
    if missing:
        raise InputError(f"missing arrays: {', '.join(missing)}", path=path)
    a = {name: _check_array(name, raw[name], path) for name in _SHAPES}
    try:
        fps = float(meta["fps"])
        n_iter = int(meta["head"]["n_iter"])
        proposal = float(meta["head"]["proposal"])
        lambdas = tuple(float(x) for x in meta["gaze"]["lambdas"])
        gaze_on = bool(meta["gaze"]["enabled"])
        top_share = float(meta["eyelids"]["top_share"])
        shape = tuple(float(x) for x in meta["eyelids"]["shape_s"])
        window = float(meta.get("talk_window_s", 0.5))
        norm_s = float(meta["speech"]["speaker_normalisation_s"])
        summary = dict(meta.get("training", {}))
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"bad or missing setting {exc}", path=path, field="meta") from None
    if (
        fps <= 0
        or n_iter < 0
        or not proposal > 0
        or len(lambdas) != 2
        or len(shape) != 3
        or min(shape) <= 0
        or not norm_s >= 0
    ):
        raise InputError(
            "settings out of range (fps, n_iter, proposal, lambdas, blink shape, "
            "speaker normalisation)",
            path=path,
            field="meta",
        )
    for name, sd in (
        ("head_kin_std", a["head_kin_std"]),
        ("head_step_std", a["head_step_std"]),
        ("eyelid_blink", a["eyelid_blink"][:, 1]),
        ("gaze_fixation_intervals", a["gaze_fixation_intervals"][:, 1]),
    ):
        if np.any(sd <= 0):
            raise InputError("standard deviations must be positive", path=path, field=name)
    pose = SpeechPose.from_array(a["head_expectation"], fps)
    stationary = all(
        np.all(np.abs(np.roots([1.0, -p[0], -p[1]])) < 1.0) for p in pose.ar if np.any(p != 0)
    )
    if np.any(pose.tau_s < 0) or np.any(pose.innovation_sd < 0) or not stationary:
        raise InputError(
            "time constants and sds must not be negative, the variation must be stationary",
            path=path,
            field="head_expectation",
        )
    if np.any(a["gaze_fixation_offsets"][:, 2:] < 0):
        raise InputError(
            "standard deviations must not be negative", path=path, field="gaze_fixation_offsets"
        )
    head = HeadModel(
        _mixtures(a, "head_voiced", path),
        _mixtures(a, "head_unvoiced", path),
        a["head_kin_mean"],
        a["head_kin_std"],
        a["head_step_std"],
        a["head_weights"],
        n_iter,
        proposal,
    )
    gaze = GazeModel(
        a["gaze_h_mean"],
        a["gaze_h_std"],
        a["gaze_phi_mean"],
        a["gaze_phi_std"],
        a["gaze_u"],
        a["gaze_ce_t"],
        a["gaze_a_t"],
        a["gaze_v_star"],
        a["gaze_e_mean"],
        a["gaze_e_std"],
        a["gaze_correlations"],
        (lambdas[0], lambdas[1]),
        gaze_on,
    )
    eyelids = EyelidModel(
        a["eyelid_cb"], a["eyelid_blink"], top_share, (shape[0], shape[1], shape[2])
    )
    fixations = FixationModel(a["gaze_fixation_intervals"], a["gaze_fixation_offsets"])
    return LiveModel(
        fps,
        SpeechScale.from_array(a["speech_scale"]),
        head,
        gaze,
        eyelids,
        fixations,
        summary,
        window,
        pose,
        norm_s,
    )
