"""The live model's file: :func:`save_model` writes a :class:`~app.stimuli.live.model.LiveModel`,
:func:`load_model` reads one back and checks it.

File format (``.npz``, read with ``allow_pickle=False``; see docs/reference/live.md): numeric arrays
named below plus ``meta``, a UTF-8 JSON document stored as a uint8 array, holding the format name
and version, the frame rate, the settings and the training summary (frames, fps, channels, ...).
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.live.expectation import SpeechPose
from app.stimuli.live.eyelids import EyelidModel
from app.stimuli.live.gaze import FixationModel, GazeModel
from app.stimuli.live.head import HeadModel
from app.stimuli.live.inputs import SpeechScale
from app.stimuli.live.mixture import Mixture, MixtureBank
from app.stimuli.live.model import LiveModel

FORMAT = "facepair-live-gmm"
VERSION = 3
_MIX = ("weights", "means", "covariances")
_GAZE = (
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
)


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
    for name in _GAZE:
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


@dataclass(frozen=True)
class _Settings:
    """The settings of a model file's ``meta``, read and checked."""

    fps: float
    n_iter: int
    proposal: float
    lambdas: tuple[float, float]
    gaze_on: bool
    top_share: float
    shape: tuple[float, float, float]
    window: float
    norm_s: float
    summary: dict[str, Any]


def _read_archive(path: Path) -> dict[str, np.ndarray]:
    """Every array of the ``.npz`` archive at ``path``, by name, pickled objects refused."""
    try:
        with open(path, "rb") as fh:
            npz = np.load(fh, allow_pickle=False)
            if not isinstance(npz, np.lib.npyio.NpzFile):
                raise InputError(
                    "not a live model file: a single array, not an .npz archive", path=path
                )
            with npz:
                return {k: npz[k] for k in npz.files}
    except FileNotFoundError:
        raise InputError("no such model file", path=path) from None
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise InputError(f"not a live model file (.npz): {exc}", path=path) from None


def _read_meta(raw: dict[str, np.ndarray], path: Path) -> dict[str, Any]:
    """The archive's ``meta`` document, once its format name and version are this program's."""
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
    return meta


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


def _read_arrays(raw: dict[str, np.ndarray], path: Path) -> dict[str, np.ndarray]:
    """Every array of :data:`_SHAPES`, each of its shape and finite, as float64."""
    missing = sorted(set(_SHAPES) - set(raw))
    if missing:
        raise InputError(f"missing arrays: {', '.join(missing)}", path=path)
    return {name: _check_array(name, raw[name], path) for name in _SHAPES}


def _read_settings(meta: dict[str, Any], path: Path) -> _Settings:
    """The settings of ``meta``, each present, of its type and in its range."""
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
    return _Settings(
        fps,
        n_iter,
        proposal,
        (lambdas[0], lambdas[1]),
        gaze_on,
        top_share,
        (shape[0], shape[1], shape[2]),
        window,
        norm_s,
        summary,
    )


def _check_spreads(a: dict[str, np.ndarray], pose: SpeechPose, path: Path) -> None:
    """Refuse negative or zero standard deviations and a variation that is not stationary."""
    for name, sd in (
        ("head_kin_std", a["head_kin_std"]),
        ("head_step_std", a["head_step_std"]),
        ("eyelid_blink", a["eyelid_blink"][:, 1]),
        ("gaze_fixation_intervals", a["gaze_fixation_intervals"][:, 1]),
    ):
        if np.any(sd <= 0):
            raise InputError("standard deviations must be positive", path=path, field=name)
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
    raw = _read_archive(path)
    meta = _read_meta(raw, path)
    a = _read_arrays(raw, path)
    s = _read_settings(meta, path)
    pose = SpeechPose.from_array(a["head_expectation"], s.fps)
    _check_spreads(a, pose, path)
    head = HeadModel(
        _mixtures(a, "head_voiced", path),
        _mixtures(a, "head_unvoiced", path),
        a["head_kin_mean"],
        a["head_kin_std"],
        a["head_step_std"],
        a["head_weights"],
        s.n_iter,
        s.proposal,
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
        s.lambdas,
        s.gaze_on,
    )
    eyelids = EyelidModel(a["eyelid_cb"], a["eyelid_blink"], s.top_share, s.shape)
    fixations = FixationModel(a["gaze_fixation_intervals"], a["gaze_fixation_offsets"])
    return LiveModel(
        s.fps,
        SpeechScale.from_array(a["speech_scale"]),
        head,
        gaze,
        eyelids,
        fixations,
        s.summary,
        s.window,
        pose,
        s.norm_s,
    )
