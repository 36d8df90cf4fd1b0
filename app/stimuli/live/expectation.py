"""The speech-driven head pose: the angle GMMs' conditional expectation, aligned in time, and the
variation speech does not predict (a departure from Le, Ma & Deng 2012 sec. 5.2, measured in
docs/reference/live.md, "Why the head did not follow the speech").

The three angle GMMs of sec. 5.1 (one per Euler angle, over the standardised (angle, pitch,
loudness), or (angle, loudness) on unvoiced frames; :mod:`app.stimuli.live.head`) are read by
their *conditional expectation* given the frame's speech (Gaussian mixture regression,
:meth:`app.stimuli.live.mixture.MixtureBank.conditional_mean`), the pose that eq. 3's angle
factors predict on average. A motion does not follow speech at once: the expectation is passed
through a causal first-order low-pass whose time constant (one of :data:`ALIGN_TAUS_S`), gain
and offset are fitted per angle by least squares to the training motion (the *alignment*). The
result is the pose's speech-driven part.

What speech does not predict (posture drift, turns, jitter) is the training motion minus that
part, the *residual*. Generation adds to the speech-driven part a draw of a per-angle AR(2)
process fitted to the residual by least squares: eq. 1's kinematics (the pose given its two
previous values) in their linear-Gaussian form. Its stationary variance is the residual's, so
the pose has the training motion's amplitude, and its spectrum follows the residual's, so no
jitter is added. ``variation`` scales it (0: the speech-driven part alone, the analogue of the
paper's maximum).

Why (measured on the held-out split, ``benchmarks/bench_live_diagnosis.py`` step d): drawn
frame by frame near the previous pose (the earlier departure, ``synthesis="langevin"``), the
pose moves by steps of the size of the training motion's frame-to-frame change (eq. 5's start
noise, 17 Langevin steps of 0.05 sigma^2), and the angle factors - mixtures of ten narrow
components, each a posture of the training motion - pull it towards the nearest component, not
to where the speech puts the head (that is in the components' weights). The pose random-walks
with the training motion's amplitude; its correlation with the GMMs' expectation was 0.02-0.12
per angle, and dropping eq. 5's start noise or the speed and acceleration factors did not change
that. Climbing to the local maximum instead (the paper) follows the nearest mode: pitch (r with
the expectation about 0.5), not the version-1 reference speaker's yaw (0.01), with 43-65 % of the
truth's sd.

Frame rate: the alignment's time constants are seconds; the AR(2) coefficients are per frame of
the training rate and are mapped to another rate through their characteristic roots
(:func:`ar2_at_rate`), keeping the stationary variance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.stimuli.live.head import HeadModel

#: Time constants (s) the alignment low-pass may take; 0 is no low-pass.
ALIGN_TAUS_S = (0.0, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0)
#: Roots of the variation's AR(2) are kept inside this radius (stationarity).
MAX_ROOT = 0.999
#: The variation's state starts from a draw of this long a run (s), so it is stationary from the
#: first frame.
BURN_IN_S = 10.0


@dataclass(frozen=True)
class SpeechPose:
    """Alignment and variation per angle (yaw, pitch, roll), at the training frame rate."""

    tau_s: np.ndarray  # (3,) time constant of the alignment low-pass, seconds (0: none)
    gain: np.ndarray  # (3,) gain on the low-passed expectation
    offset: np.ndarray  # (3,) degrees
    ar: np.ndarray  # (3, 2) AR(2) coefficients of the variation, per frame at ``fps``
    innovation_sd: np.ndarray  # (3,) degrees
    fps: float

    def to_array(self) -> np.ndarray:
        """(3, 6): tau, gain, offset, ar1, ar2, innovation sd per angle."""
        return np.column_stack(
            [self.tau_s, self.gain, self.offset, self.ar, self.innovation_sd]
        ).astype(np.float64)

    @classmethod
    def from_array(cls, a: np.ndarray, fps: float) -> SpeechPose:
        a = np.asarray(a, dtype=np.float64)
        return cls(
            a[:, 0].copy(), a[:, 1].copy(), a[:, 2].copy(), a[:, 3:5].copy(), a[:, 5].copy(), fps
        )

    def variation_sd(self) -> np.ndarray:
        """Stationary sd of each angle's variation (degrees)."""
        return np.array(
            [
                math.sqrt(ar2_variance(p[0], p[1], s))
                for p, s in zip(self.ar, self.innovation_sd, strict=True)
            ]
        )


def expectations(head: HeadModel, pitch_z: np.ndarray, loud_z: np.ndarray) -> np.ndarray:
    """(n, 3) expected (yaw, pitch, roll) in degrees for standardised pitch (NaN unvoiced) and
    loudness per frame: the conditional means of the three angle mixtures."""
    pz = np.asarray(pitch_z, dtype=np.float64)
    lz = np.asarray(loud_z, dtype=np.float64)
    out = np.empty((len(pz), 3))
    voiced = np.isfinite(pz)
    if voiced.any():
        fixed = np.broadcast_to(
            np.column_stack([pz[voiced], lz[voiced]])[:, None, :], (int(voiced.sum()), 5, 2)
        )
        out[voiced] = head.voiced.conditional_mean(fixed)[:, :3]
    if (~voiced).any():
        fixed = np.broadcast_to(lz[~voiced][:, None, None], (int((~voiced).sum()), 5, 1))
        out[~voiced] = head.unvoiced.conditional_mean(fixed)[:, :3]
    return out * head.kin_std[:3] + head.kin_mean[:3]


def frame_expectation(head: HeadModel, pitch_z: float, loud_z: float) -> np.ndarray:
    """(3,) expected (yaw, pitch, roll) in degrees for one frame (see :func:`expectations`)."""
    if pitch_z != pitch_z:
        z = head.unvoiced.conditional_mean(np.full((5, 1), loud_z))
    else:
        fixed = np.empty((5, 2))
        fixed[:, 0] = pitch_z
        fixed[:, 1] = loud_z
        z = head.voiced.conditional_mean(fixed)
    return z[:3] * head.kin_std[:3] + head.kin_mean[:3]


def low_pass_gain(tau_s: float, fps: float) -> float:
    """Gain ``k`` of ``y_t = y_{t-1} + k (x_t - y_{t-1})`` for time constant ``tau_s`` (1 if 0)."""
    return 1.0 if tau_s <= 0 else 1.0 - math.exp(-1.0 / (tau_s * fps))


def _low_pass(x: np.ndarray, k: float, start: float) -> np.ndarray:
    from scipy import signal  # where the alignment is fitted only (its import takes 0.4 s)

    return signal.lfilter([k], [1.0, -(1.0 - k)], x, zi=[(1.0 - k) * start])[0]


def ar2_variance(a1: float, a2: float, sd: float) -> float:
    """Stationary variance of ``x_t = a1 x_{t-1} + a2 x_{t-2} + sd e_t``."""
    den = (1.0 + a2) * ((1.0 - a2) ** 2 - a1 * a1)
    return sd * sd * (1.0 - a2) / den if den > 0 else 0.0


def _ar2_from_roots(roots: np.ndarray) -> tuple[float, float]:
    return float(np.real(roots[0] + roots[1])), float(-np.real(roots[0] * roots[1]))


def _stable(a1: float, a2: float) -> tuple[float, float]:
    """The AR(2) with its characteristic roots pulled inside :data:`MAX_ROOT`."""
    roots = np.roots([1.0, -a1, -a2])
    if len(roots) < 2:
        roots = np.r_[roots, 0.0][:2]
    big = np.abs(roots) > MAX_ROOT
    roots = np.where(big, roots / np.abs(roots) * MAX_ROOT, roots)
    return _ar2_from_roots(roots)


def ar2_at_rate(a1: float, a2: float, sd: float, fps_from: float, fps_to: float) -> tuple:
    """The AR(2) ``(a1, a2, sd)`` of ``fps_from`` at ``fps_to``: each characteristic root ``r``
    becomes ``r ** (fps_from / fps_to)`` (a negative real root, which has no counterpart, its
    magnitude), and the innovation sd keeps the stationary variance."""
    if fps_from == fps_to:
        return a1, a2, sd
    roots = np.roots([1.0, -a1, -a2]).astype(complex)
    if len(roots) < 2:
        roots = np.r_[roots, 0.0][:2]
    ratio = fps_from / fps_to
    roots = np.where((np.abs(roots.imag) < 1e-12) & (roots.real < 0), np.abs(roots) + 0j, roots)
    new = np.array([r**ratio if r != 0 else 0j for r in roots])
    b1, b2 = _ar2_from_roots(new)
    var = ar2_variance(a1, a2, sd)
    unit = ar2_variance(b1, b2, 1.0)
    return b1, b2, math.sqrt(var / unit) if unit > 0 else 0.0


def fit_speech_pose(
    head: HeadModel,
    angles: np.ndarray,
    pitch_z: np.ndarray,
    loud_z: np.ndarray,
    fps: float,
    starts: Sequence[int] = (0,),
) -> tuple[SpeechPose, dict[str, Any]]:
    """Fit the alignment and the variation (module docstring) to training frames: ``angles``
    (n, 3) yaw, pitch, roll in degrees, the standardised speech the mixtures were fitted on,
    ``starts`` the first frame of each take. Returns the fit and a JSON-able summary."""
    angles = np.asarray(angles, dtype=np.float64)
    n = len(angles)
    bounds = list(starts) + [n]
    pieces = [(bounds[i], bounds[i + 1]) for i in range(len(bounds) - 1)]
    expect = expectations(head, pitch_z, loud_z)
    rest = head.kin_mean[:3]
    tau, gain, offset, r2 = np.zeros(3), np.ones(3), np.zeros(3), np.zeros(3)
    aligned = np.empty_like(angles)
    for g in range(3):
        y = angles[:, g]
        best: tuple[float, float, np.ndarray, np.ndarray] | None = None
        for t in ALIGN_TAUS_S:
            k = low_pass_gain(t, fps)
            x = np.concatenate([_low_pass(expect[a:b, g], k, rest[g]) for a, b in pieces])
            design = np.column_stack([x, np.ones(n)])
            coef, *_ = np.linalg.lstsq(design, y, rcond=None)
            fit = design @ coef
            score = 1.0 - float(np.var(y - fit)) / max(float(np.var(y)), 1e-12)
            if best is None or score > best[0]:
                best = (score, t, coef, fit)
        assert best is not None
        r2[g], tau[g], (gain[g], offset[g]), aligned[:, g] = best
    residual = angles - aligned
    ar = np.zeros((3, 2))
    sd = np.zeros(3)
    for g in range(3):
        rows, target = [], []
        for a, b in pieces:
            x = residual[a:b, g]
            if len(x) > 2:
                rows.append(np.column_stack([x[1:-1], x[:-2]]))
                target.append(x[2:])
        if not rows:
            continue
        design, y = np.vstack(rows), np.concatenate(target)
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        a1, a2 = _stable(float(coef[0]), float(coef[1]))
        ar[g] = (a1, a2)
        # innovation sd that keeps the residual's variance (the same as the least-squares
        # innovations' when the fit was stable)
        unit = ar2_variance(a1, a2, 1.0)
        sd[g] = math.sqrt(float(np.var(residual[:, g])) / unit) if unit > 0 else 0.0
    pose = SpeechPose(tau, gain, offset, ar, sd, float(fps))
    summary = {
        "alignment_tau_s": tau.tolist(),
        "alignment_gain": gain.tolist(),
        "speech_r2": r2.tolist(),
        "speech_sd_deg": aligned.std(axis=0).tolist(),
        "variation_sd_deg": pose.variation_sd().tolist(),
        "order": ["yaw", "pitch", "roll"],
    }
    return pose, summary


class PoseTracker:
    """Streaming head pose from per-frame expectations: the aligned expectation plus
    ``variation`` times the AR(2) draw (module docstring). Draws from ``rng`` in frame order
    (a burn-in of :data:`BURN_IN_S` at construction)."""

    def __init__(
        self,
        pose: SpeechPose,
        rest: np.ndarray,
        fps: float,
        rng: np.random.Generator,
        variation: float = 1.0,
    ) -> None:
        self.pose = pose
        self._k = np.array([low_pass_gain(float(t), fps) for t in pose.tau_s])
        self._state = np.asarray(rest, dtype=np.float64).copy()
        params = [
            ar2_at_rate(float(p[0]), float(p[1]), float(s), pose.fps, fps)
            for p, s in zip(pose.ar, pose.innovation_sd, strict=True)
        ]
        self._a1 = np.array([p[0] for p in params])
        self._a2 = np.array([p[1] for p in params])
        self._sd = np.array([p[2] for p in params])
        self._variation = float(variation)
        self._rng = rng
        self._x1, self._x2 = np.zeros(3), np.zeros(3)
        burn = rng.standard_normal((max(1, int(round(BURN_IN_S * fps))), 3)) * self._sd
        for e in burn:
            self._x1, self._x2 = self._a1 * self._x1 + self._a2 * self._x2 + e, self._x1

    def step(self, expectation: np.ndarray) -> np.ndarray:
        """The next pose (3,) in degrees from this frame's expectation."""
        self._state = self._state + self._k * (expectation - self._state)
        e = self._rng.standard_normal(3) * self._sd
        self._x1, self._x2 = self._a1 * self._x1 + self._a2 * self._x2 + e, self._x1
        return self.pose.offset + self.pose.gain * self._state + self._variation * self._x1
