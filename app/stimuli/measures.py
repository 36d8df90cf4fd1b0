"""Objective measures of a motion track, so experimenters can look before they run people.

Per channel: mean, sd, range, and velocity and acceleration statistics (finite differences,
per second). Against speech: Pearson correlation of each channel with the conditioned F0 and
the intensity, and the canonical correlations between the head angles (and the eyebrows) and
the pair (F0, intensity) - the measure used for generated head motion in the literature (see
the project's speech-and-models notes). Against ground truth: RMSE and correlation per channel.
Head kinematics as in Le, Ma & Deng (2012): angular speed ``v = sqrt(sum dtheta^2)`` and
acceleration ``a = sqrt(sum d2theta^2)`` over (pitch, yaw, roll), here in degrees per second
(squared).

Undefined values (a constant channel's correlation) are ``None`` so the result is valid JSON.

Example
-------
>>> import numpy as np
>>> x = np.arange(10.0)
>>> round(canonical_correlations(x[:, None], (2 * x + 1)[:, None])[0], 9)
1.0
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from app.stimuli.fap import DEG_PER_AU, EYEBROW_RAISE, HEAD
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


def _num(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def pearson(x: np.ndarray, y: np.ndarray) -> float | None:
    """Pearson correlation, ``None`` if either series is constant or too short."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if len(x) < 2 or x.std() == 0 or y.std() == 0:
        return None
    return _num(np.corrcoef(x, y)[0, 1])


def canonical_correlations(x: np.ndarray, y: np.ndarray) -> list[float]:
    """Canonical correlations of two multivariate series (rows = frames), largest first.

    Exact, not iterative: with centred data and orthonormal bases ``Qx``, ``Qy`` of their
    column spaces (QR), the canonical correlations are the singular values of ``Qx' Qy``
    (Bjorck & Golub 1973). Constant columns are dropped first.
    """
    x = np.asarray(x, float).reshape(len(x), -1)
    y = np.asarray(y, float).reshape(len(y), -1)
    x = x[:, x.std(axis=0) > 0] - x.mean(axis=0)[x.std(axis=0) > 0]
    y = y[:, y.std(axis=0) > 0] - y.mean(axis=0)[y.std(axis=0) > 0]
    if x.shape[1] == 0 or y.shape[1] == 0 or len(x) < 2:
        return []
    qx, qy = _basis(x), _basis(y)
    s = np.linalg.svd(qx.T @ qy, compute_uv=False)
    return [float(v) for v in np.clip(s, 0.0, 1.0)]


def _basis(a: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the column space (rank-revealing through the SVD)."""
    u, s, _ = np.linalg.svd(a, full_matrices=False)
    rank = int(np.sum(s > s[0] * 1e-10)) if len(s) else 0
    return u[:, :rank]


def channel_stats(
    track: MotionTrack, channels: Iterable[int] | None = None
) -> dict[str, dict[str, float | None]]:
    """Mean, sd, range, and velocity/acceleration statistics (FAPU/s, FAPU/s^2) per channel."""
    out: dict[str, dict[str, float | None]] = {}
    for c in channels if channels is not None else track.channels:
        if c not in track.channels:
            continue
        x = track[c]
        vel = np.diff(x) * track.fps
        acc = np.diff(x, 2) * track.fps**2
        out[str(c)] = {
            "mean": _num(x.mean()) if len(x) else None,
            "std": _num(x.std()) if len(x) else None,
            "min": _num(x.min()) if len(x) else None,
            "max": _num(x.max()) if len(x) else None,
            "velocity_mean_abs": _num(np.abs(vel).mean()) if len(vel) else None,
            "velocity_std": _num(vel.std()) if len(vel) else None,
            "velocity_max_abs": _num(np.abs(vel).max()) if len(vel) else None,
            "acceleration_mean_abs": _num(np.abs(acc).mean()) if len(acc) else None,
            "acceleration_std": _num(acc.std()) if len(acc) else None,
        }
    return out


def head_kinematics(track: MotionTrack) -> dict[str, float | None]:
    """Angular speed and acceleration of the head over (pitch, yaw, roll), in degrees."""
    angles = np.column_stack([track.get(c) for c in HEAD]) * DEG_PER_AU
    if len(angles) < 3:
        return {"speed_mean_deg_s": None, "speed_max_deg_s": None, "acceleration_mean_deg_s2": None}
    v = np.sqrt(np.sum((np.diff(angles, axis=0) * track.fps) ** 2, axis=1))
    a = np.sqrt(np.sum((np.diff(angles, 2, axis=0) * track.fps**2) ** 2, axis=1))
    return {
        "speed_mean_deg_s": _num(v.mean()),
        "speed_max_deg_s": _num(v.max()),
        "acceleration_mean_deg_s2": _num(a.mean()),
    }


def speech_relation(
    track: MotionTrack, features: SpeechFeatures, channels: Iterable[int] = HEAD + EYEBROW_RAISE
) -> dict[str, Any]:
    """Correlations with conditioned F0 and intensity; canonical correlations per group."""
    speech = np.column_stack([features.f0_conditioned, features.intensity])
    per_channel = {
        str(c): {
            "f0": pearson(track[c], features.f0_conditioned),
            "intensity": pearson(track[c], features.intensity),
        }
        for c in channels
        if c in track.channels
    }
    groups = {}
    for label, group in (("head", HEAD), ("eyebrows", EYEBROW_RAISE)):
        cols = [track[c] for c in group if c in track.channels]
        groups[label] = canonical_correlations(np.column_stack(cols), speech) if cols else []
    return {"correlation": per_channel, "canonical_correlation": groups}


def compare_to_reference(
    track: MotionTrack, reference: MotionTrack, channels: Iterable[int] = HEAD + EYEBROW_RAISE
) -> dict[str, dict[str, float | None]]:
    """RMSE and correlation of each channel to the reference (ground truth), frame by frame."""
    n = min(track.n_frames, reference.n_frames)
    out = {}
    for c in channels:
        if c in track.channels and c in reference.channels and n:
            x, r = track[c][:n], reference[c][:n]
            out[str(c)] = {
                "rmse": _num(np.sqrt(np.mean((x - r) ** 2))),
                "correlation": pearson(x, r),
            }
    return out


def measure_track(
    track: MotionTrack, features: SpeechFeatures, ground_truth: MotionTrack | None = None
) -> dict[str, Any]:
    """All measures of one condition track (JSON-able)."""
    prosody = [c for c in HEAD + EYEBROW_RAISE if c in track.channels]
    d: dict[str, Any] = {
        "channels": channel_stats(track, prosody),
        "head": head_kinematics(track),
        "speech": speech_relation(track, features),
    }
    if ground_truth is not None:
        d["ground_truth"] = compare_to_reference(track, ground_truth)
    return d
