"""Speech-driven head motion: five GMMs, gradient ascent per frame (Le, Ma & Deng 2012, sec. 5).

Training (sec. 5.1). From the head's Euler angles (yaw, pitch, roll; degrees) the five kinematic
features of eq. 1 are computed per frame,

    v_t = fps ||theta_t - theta_{t-1}||,   a_t = fps^2 ||theta_t - 2 theta_{t-1} + theta_{t-2}||,

(angular speed in deg/s and acceleration in deg/s^2), and for each feature kappa a 10-component
full-covariance mixture (eq. 2) is fitted by EM to the standardised tuples (kappa, p, l) of the
voiced frames. *Unvoiced frames* have no pitch: a second set of five mixtures over (kappa, l) is
fitted to the unvoiced training frames (or, with fewer than :data:`MIN_UNVOICED` of them, taken
as the (kappa, l) marginals of the voiced mixtures). At synthesis an unvoiced frame maximises
the product of the unvoiced densities P(kappa | l): the head keeps moving in pauses, driven by
loudness alone, instead of freezing or reading a made-up pitch.

Synthesis (sec. 5.2, eq. 3-5). Given the frame's speech and the two previous poses, the
objective is the log of eq. 4's product,

    J(theta) = sum_kappa w_kappa log P_kappa(kappa_t(theta), p_t, l_t),

with the paper's equal weights ``w_kappa = 1`` by default. Its gradient is analytic: with
responsibilities ``gamma_k`` and the component quadratics of :mod:`app.stimuli.live.mixture`,
``dJ/dkappa = sum_k gamma_k (a1_k + 2 a2_k kappa)``, chained through eq. 1
(``dv/dtheta = fps (theta - theta_{t-1}) / ||.||``, zero where the norm is zero: the one
non-differentiable point the paper mentions). The search starts from the previous pose plus
``N(0, sigma^2)`` (eq. 5), sigma being the per-axis standard deviation of the frame-to-frame
change of the training poses, and takes 17 gradient steps (the paper's mean iteration count).

*Departure (measured, docs/reference/live.md):* the paper climbs to the local maximum of J; here
each of the 17 steps is a Metropolis-adjusted Langevin step (a gradient step plus Gaussian noise,
accepted with the Metropolis-Hastings probability), so the pose is a draw from the
distribution ``exp(J)`` of eq. 3 near the previous pose instead of its mode. The maximum has
about 40 % of the ground truth's head sd on held-out speech, since the part of the motion that
speech does not predict is averaged away; the draw keeps it (98-113 %), with no more power
above 4 Hz than the ground truth. Proposals have per-axis variance ``proposal x sigma^2``
(:data:`DEFAULT_PROPOSAL`); the cost per frame stays fixed.

Since file version 3 this draw is not the generator's default: it random-walks between the
postures the angle mixtures encode and keeps little of what the speech predicts (held-out r with
the truth about 0; docs/reference/live.md, "Why the head did not follow the speech"). The
generator reads the mixtures by their conditional expectation instead
(:mod:`app.stimuli.live.expectation`); this sampler serves ``synthesis="langevin"``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from app.stimuli.live.mixture import Mixture, MixtureBank, fit_mixture

#: Names of the five kinematic features, in the order used everywhere.
KINEMATIC = ("yaw", "pitch", "roll", "velocity", "acceleration")
#: Fewer unvoiced training frames than this: use the voiced mixtures' (kappa, l) marginals.
MIN_UNVOICED = 150
#: Default exponents of the five likelihoods in eq. 4 (yaw, pitch, roll, velocity,
#: acceleration): the paper's plain product.
DEFAULT_WEIGHTS = (1.0, 1.0, 1.0, 1.0, 1.0)
#: Default variance of the Langevin proposals, in units of eq. 5's sigma^2.
DEFAULT_PROPOSAL = 0.05


def kinematic_features(angles: np.ndarray, fps: float) -> np.ndarray:
    """Eq. 1: (n, 3) Euler angles in degrees -> (n, 5) (yaw, pitch, roll, v, a).

    The first frame's velocity and the first two frames' acceleration are undefined; they are
    NaN here (training drops those frames).
    """
    angles = np.asarray(angles, dtype=np.float64)
    n = len(angles)
    out = np.full((n, 5), np.nan)
    out[:, :3] = angles
    if n > 1:
        out[1:, 3] = fps * np.linalg.norm(np.diff(angles, axis=0), axis=1)
    if n > 2:
        out[2:, 4] = fps * fps * np.linalg.norm(np.diff(angles, n=2, axis=0), axis=1)
    return out


class FrameSlice(NamedTuple):
    """One frame's mixtures as quadratics in the standardised kinematic features ``z_g``.

    ``coef[g, k] = (a0, a1, a2)``: component k of mixture g has log density
    ``a0 + a1 z_g + a2 z_g^2`` (constant terms included, :mod:`app.stimuli.live.mixture`);
    ``moments[g, k] = (1, a1, a2)``, so that one product with the components' weights gives
    the sums the gradient needs.
    """

    coef: np.ndarray  # (5, K, 3)
    moments: np.ndarray  # (5, K, 3)


@dataclass(frozen=True)
class HeadModel:
    """The trained head model: mixtures, feature scaling and synthesis settings."""

    voiced: MixtureBank  # five mixtures over standardised (kappa, p, l)
    unvoiced: MixtureBank  # five mixtures over standardised (kappa, l)
    kin_mean: np.ndarray  # (5,) mean of each kinematic feature
    kin_std: np.ndarray  # (5,) standard deviation of each kinematic feature
    step_std: np.ndarray  # (3,) std of the per-axis angle change, in deg/s (eq. 5 sigma * fps)
    weights: np.ndarray  # (5,) exponent of each likelihood in eq. 4
    n_iter: int = 17
    proposal: float = DEFAULT_PROPOSAL  # Langevin proposal variance / sigma^2

    def frame_coefficients(self, pitch_z: float, loud_z: float) -> FrameSlice:
        """The frame's component log densities as quadratics in the standardised kinematic
        coordinates (see :class:`FrameSlice`); unvoiced (``pitch_z`` NaN) frames use the
        unvoiced mixtures."""
        if pitch_z != pitch_z:
            a0, a1, a2 = self.unvoiced.slice_coefficients(np.full((5, 1), loud_z))
        else:
            fixed = np.empty((5, 2))
            fixed[:, 0] = pitch_z
            fixed[:, 1] = loud_z
            a0, a1, a2 = self.voiced.slice_coefficients(fixed)
        return FrameSlice(
            np.stack([a0, a1, a2], axis=-1), np.stack([np.ones_like(a1), a1, a2], axis=-1)
        )

    def objective(
        self, theta: np.ndarray, prev1: np.ndarray, prev2: np.ndarray, fps: float, frame: FrameSlice
    ) -> tuple[float, np.ndarray]:
        """J(theta) of eq. 4 (log, up to a constant) and its analytic gradient (3,).

        With ``e_gk = a0 + a1 z_g + a2 z_g^2`` and ``w_gk = exp(e_gk - max_k e_gk)``:
        ``log P_g = max_k e_gk + log sum_k w_gk`` and
        ``d log P_g / d z_g = sum_k w_gk (a1 + 2 a2 z_g) / sum_k w_gk``.
        """
        dy, dp, dr = theta[0] - prev1[0], theta[1] - prev1[1], theta[2] - prev1[2]
        ay, ap, ar = dy - prev1[0] + prev2[0], dp - prev1[1] + prev2[1], dr - prev1[2] + prev2[2]
        nv = math.sqrt(dy * dy + dp * dp + dr * dr)
        na = math.sqrt(ay * ay + ap * ap + ar * ar)
        powers = np.empty((5, 3, 1))
        powers[:, 0, 0] = 1.0
        powers[:, 1, 0] = (theta[0], theta[1], theta[2], fps * nv, fps * fps * na)
        z = powers[:, 1, 0]
        z -= self.kin_mean
        z /= self.kin_std
        powers[:, 2, 0] = z * z
        e = (frame.coef @ powers)[:, :, 0]
        top = e.max(axis=1)
        w = np.exp(e - top[:, None])
        sums = (w[:, None, :] @ frame.moments)[:, 0, :]  # sum w, sum w a1, sum w a2
        logp = top + np.log(sums[:, 0])
        dk = (sums[:, 1] + 2.0 * z * sums[:, 2]) / sums[:, 0] * self._grad_scale
        g0, g1, g2 = float(dk[0]), float(dk[1]), float(dk[2])
        if nv > 0.0:
            c = float(dk[3]) * fps / nv
            g0, g1, g2 = g0 + c * dy, g1 + c * dp, g2 + c * dr
        if na > 0.0:
            c = float(dk[4]) * fps * fps / na
            g0, g1, g2 = g0 + c * ay, g1 + c * ap, g2 + c * ar
        return float(self.weights @ logp), np.array([g0, g1, g2])

    @property
    def _grad_scale(self) -> np.ndarray:
        return self.weights / self.kin_std

    def sample(
        self,
        start: np.ndarray,
        prev1: np.ndarray,
        prev2: np.ndarray,
        fps: float,
        frame: FrameSlice,
        rng: np.random.Generator,
    ) -> np.ndarray:
        """The frame's pose: ``n_iter`` Metropolis-adjusted Langevin steps on J from ``start``
        (eq. 5's draw), targeting ``exp(J)``.

        With ``M = proposal sigma^2`` (per axis) a step proposes
        ``c = theta + M g(theta) / 2 + sqrt(M) xi`` and accepts it with probability
        ``min(1, exp(J(c) - J(theta) + log q(theta | c) - log q(c | theta)))``,
        ``q(b | a) ~ exp(-||b - a - M g(a) / 2||^2_M / 2)``. Draws two arrays from ``rng``.
        """
        m = self.proposal * (self.step_std / fps) ** 2
        root = np.sqrt(m)
        noise = rng.standard_normal((self.n_iter, 3)) * root
        log_u = np.log(rng.random(self.n_iter))
        theta = start
        f, g = self.objective(theta, prev1, prev2, fps, frame)
        for i in range(self.n_iter):
            cand = theta + 0.5 * m * g + noise[i]
            fc, gc = self.objective(cand, prev1, prev2, fps, frame)
            back = theta - cand - 0.5 * m * gc  # theta minus the mean of q(. | cand)
            log_q_ratio = 0.5 * float(noise[i] @ (noise[i] / m) - back @ (back / m))
            if log_u[i] < fc - f + log_q_ratio:
                theta, f, g = cand, fc, gc
        return theta


def fit_head_model(
    angles: np.ndarray,
    pitch_z: np.ndarray,
    loud_z: np.ndarray,
    fps: float,
    *,
    starts: Sequence[int] = (0,),
    n_components: int = 10,
    seed: int = 0,
    n_iter: int = 17,
    weights: Sequence[float] | None = None,
    proposal: float = DEFAULT_PROPOSAL,
    progress: Callable[[], None] | None = None,
) -> HeadModel:
    """Fit the ten mixtures of the head model (sec. 5.1) to training frames.

    ``angles`` (n, 3): yaw, pitch, roll in degrees; ``pitch_z`` (n,) standardised pitch with NaN
    on unvoiced frames; ``loud_z`` (n,) standardised loudness. ``starts``: first frame of each
    take (separate recordings concatenated; velocity and acceleration never span two takes).
    ``progress`` is called after each mixture is fitted.
    """
    angles = np.asarray(angles, dtype=np.float64)
    bounds = list(starts) + [len(angles)]
    pieces = [(bounds[i], bounds[i + 1]) for i in range(len(bounds) - 1)]
    kin = np.concatenate([kinematic_features(angles[a:b], fps) for a, b in pieces])
    ok = np.all(np.isfinite(kin), axis=1) & np.isfinite(loud_z)
    kin_mean = kin[ok].mean(axis=0)
    kin_std = kin[ok].std(axis=0)
    kin_std = np.where(kin_std > 1e-9, kin_std, 1.0)
    kz = (kin - kin_mean) / kin_std
    voiced = ok & np.isfinite(pitch_z)
    unvoiced = ok & ~np.isfinite(pitch_z)
    v_mix: list[Mixture] = []
    u_mix: list[Mixture] = []
    for g in range(5):
        x = np.column_stack([kz[voiced, g], pitch_z[voiced], loud_z[voiced]])
        v_mix.append(fit_mixture(x, n_components, seed=seed + g))
        if progress:
            progress()
    for g in range(5):
        if unvoiced.sum() >= MIN_UNVOICED:
            x = np.column_stack([kz[unvoiced, g], loud_z[unvoiced]])
            u_mix.append(fit_mixture(x, n_components, seed=seed + 5 + g))
        else:
            u_mix.append(v_mix[g].marginal([0, 2]))
        if progress:
            progress()
    step = np.concatenate([np.diff(angles[a:b], axis=0) for a, b in pieces]).std(axis=0) * fps
    w = np.array(DEFAULT_WEIGHTS if weights is None else weights, dtype=np.float64)
    return HeadModel(
        MixtureBank.stack(v_mix),
        MixtureBank.stack(u_mix),
        kin_mean,
        kin_std,
        np.where(step > 1e-9, step, 1.0),
        w,
        n_iter,
        proposal,
    )
