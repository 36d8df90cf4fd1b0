"""Eye gaze from head motion and loudness by NDCCA (Le, Ma & Deng 2012, sec. 6).

Training (sec. 6.1-6.2). The head-speech vector ``h_t = (yaw, pitch, roll, loudness)`` is
standardised (training mean and standard deviation; the kernel is not scale-free, so its input
scale has to be fixed) and mapped through the kernel of eq. 10, ``phi_i = h_i^2 + h_i``. CCA
(eq. 6-7) between the standardised ``phi(h_t)`` and the standardised gaze ``e_t`` (two angles)
gives the projections ``U`` (4 x r) and ``V`` (2 x r), r = 2. The paper trains them with Lai and
Fyfe's neural network; this module solves the same problem in closed form (SVD of the whitened
cross-covariance), which gives the same basis pairs without learning-rate choices. Then, all by
linear least squares on the training frames:

- eq. 11: the coupling matrix ``Ce`` with ``Ce h^_t ~ e^_t`` (``h^ = U' phi``, ``e^ = V' e``);
- eq. 8: the back projection ``V*`` with ``V*' e^_t ~ e_t``;
- eq. 12: the dynamic transition ``A*`` with ``A* e^_{t-1} ~ e^_t``.

Synthesis per frame (eq. 13-15): ``e^_t = Ce U' phi(h_t)``, smoothed
``e^_t = lambda1 e^_t + lambda2 A* e^_{t-1}`` (0.7 and 0.3; ``e^_{t-1}`` is the previous smoothed
value, zero before the first frame), and ``e_t = V*' e^_t`` (de-standardised).

*Departure (measured, docs/reference/live.md): fixations.* Eq. 13-15 give the gaze that head and
loudness predict, a conditional mean. Where most of the gaze is not predicted by them (gaze shifts
between fixation targets), that mean barely moves: on held-out speech of the reference speaker
the NDCCA gaze has an sd of 0.2-0.3 deg against the ground truth's 3-5 deg. The unpredicted
part is therefore generated as the paper generates blinks (sec. 7.1, eq. 16, 19): saccades at
log-normal intervals per talking/listening mode, each moving the eyes to a new fixation
offset drawn from the mode's normal distribution; the offset is added to the NDCCA gaze.
Training detects the ground truth's saccades (gaze speed through :data:`SACCADE_DEG_S`), fits
the fixation intervals by maximum likelihood and takes the mean and sd of the fixations'
mean residual (ground truth minus NDCCA gaze) per mode.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from app.stimuli.live.eyelids import IntervalClock, fit_interval_params

#: Eq. 14's weights, as set in the paper.
LAMBDA1, LAMBDA2 = 0.7, 0.3
#: Gaze speed (deg/s) above which a frame belongs to a saccade.
SACCADE_DEG_S = 30.0
#: Fixation intervals for a mode with too few saccades: (mu, sigma) of ln(seconds), rows
#: (talking, listening): medians 1.2 s and 2.5 s (documented choice).
DEFAULT_FIXATION = np.array([[np.log(1.2), 0.5], [np.log(2.5), 0.5]])


def kernel(h: np.ndarray) -> np.ndarray:
    """Eq. 10: ``phi_i = h_i^2 + h_i``, elementwise."""
    return h * h + h


def _inv_sqrt(c: np.ndarray) -> np.ndarray:
    vals, vecs = np.linalg.eigh(c)
    return (vecs / np.sqrt(np.maximum(vals, 1e-12))) @ vecs.T


def cca(
    x: np.ndarray, y: np.ndarray, *, reg: float = 1e-6
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Canonical correlation analysis of centred ``x`` (n, p) and ``y`` (n, q) (eq. 6-7).

    Returns ``U`` (p, r), ``V`` (q, r) and the canonical correlations (r,), r = min(p, q), in
    decreasing order; the projections ``x @ U`` and ``y @ V`` have unit variance and are
    mutually uncorrelated except pairwise.
    """
    n = len(x)
    cxx = x.T @ x / n + reg * np.eye(x.shape[1])
    cyy = y.T @ y / n + reg * np.eye(y.shape[1])
    cxy = x.T @ y / n
    wx, wy = _inv_sqrt(cxx), _inv_sqrt(cyy)
    p, s, qt = np.linalg.svd(wx @ cxy @ wy, full_matrices=False)
    r = min(x.shape[1], y.shape[1])
    return wx @ p[:, :r], wy @ qt.T[:, :r], s[:r]


@dataclass(frozen=True)
class GazeModel:
    """A trained NDCCA gaze model. ``enabled`` is False when the training data had no gaze:
    the model then outputs the mean gaze (zero)."""

    h_mean: np.ndarray  # (4,) mean of (yaw, pitch, roll, loudness) [deg, deg, deg, dB-z]
    h_std: np.ndarray  # (4,)
    phi_mean: np.ndarray  # (4,) of the kernel features
    phi_std: np.ndarray  # (4,)
    u: np.ndarray  # (4, r) eq. 9 projection of phi(h)
    ce_t: np.ndarray  # (r, r) eq. 11 coupling matrix, transposed (row-vector convention)
    a_t: np.ndarray  # (r, r) eq. 12 dynamic transition, transposed
    v_star: np.ndarray  # (r, 2) eq. 8 back projection
    e_mean: np.ndarray  # (2,) mean gaze (yaw, pitch) in degrees
    e_std: np.ndarray  # (2,)
    correlations: np.ndarray  # (r,) canonical correlations on the training data
    lambdas: tuple[float, float] = (LAMBDA1, LAMBDA2)
    enabled: bool = True

    @property
    def r(self) -> int:
        return self.u.shape[1]

    def coupling(self) -> np.ndarray:
        """``U Ce'`` (4, r): phi_z -> e^ in one product (eq. 13)."""
        return self.u @ self.ce_t

    def step(
        self, h: np.ndarray, prev_hat: np.ndarray, coupling: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """One frame of eq. 13-15: head-speech ``h`` (4,) -> gaze (2,) in degrees and the new
        smoothed ``e^``. ``coupling`` is :meth:`coupling`, passed in so it is computed once."""
        if not self.enabled:
            return self.e_mean.copy(), prev_hat
        hz = (h - self.h_mean) / self.h_std
        phi = (kernel(hz) - self.phi_mean) / self.phi_std
        hat = self.lambdas[0] * (phi @ coupling) + self.lambdas[1] * (prev_hat @ self.a_t)
        return (hat @ self.v_star) * self.e_std + self.e_mean, hat

    def run(self, h: np.ndarray) -> np.ndarray:
        """Eq. 13-15 over (n, 4) frames (the same recursion as :meth:`step`); (n, 2) gaze."""
        coupling = self.coupling()
        prev = np.zeros(self.r)
        out = np.empty((len(h), 2))
        for t in range(len(h)):
            out[t], prev = self.step(h[t], prev, coupling)
        return out


def _std(x: np.ndarray) -> np.ndarray:
    s = x.std(axis=0)
    return np.where(s > 1e-9, s, 1.0)


def fit_gaze_model(h: np.ndarray, e: np.ndarray, starts: Sequence[int] = (0,)) -> GazeModel:
    """Fit NDCCA (sec. 6.1-6.2) to head-speech frames ``h`` (n, 4) and gaze ``e`` (n, 2);
    ``starts`` are the first frames of concatenated takes (eq. 12 pairs never span two)."""
    h = np.asarray(h, dtype=np.float64)
    e = np.asarray(e, dtype=np.float64)
    h_mean, h_std = h.mean(axis=0), _std(h)
    e_mean, e_std = e.mean(axis=0), _std(e)
    if not np.any(e.std(axis=0) > 1e-9):
        z2, z4 = np.zeros((4, 2)), np.zeros((2, 2))
        return GazeModel(
            h_mean,
            h_std,
            np.zeros(4),
            np.ones(4),
            z2,
            z4,
            z4,
            z4,
            e_mean,
            np.ones(2),
            np.zeros(2),
            enabled=False,
        )
    phi = kernel((h - h_mean) / h_std)
    phi_mean, phi_std = phi.mean(axis=0), _std(phi)
    x = (phi - phi_mean) / phi_std
    y = (e - e_mean) / e_std
    u, v, corr = cca(x, y)
    h_hat, e_hat = x @ u, y @ v
    ce_t = np.linalg.lstsq(h_hat, e_hat, rcond=None)[0]  # eq. 11
    v_star = np.linalg.lstsq(e_hat, y, rcond=None)[0]  # eq. 8
    follows = np.ones(len(e_hat), bool)
    follows[list(starts)] = False  # frame t has a predecessor in its own take
    a_t = np.linalg.lstsq(e_hat[np.flatnonzero(follows) - 1], e_hat[follows], rcond=None)[0]
    return GazeModel(h_mean, h_std, phi_mean, phi_std, u, ce_t, a_t, v_star, e_mean, e_std, corr)


def saccade_onsets(gaze: np.ndarray, fps: float, starts: Sequence[int] = (0,)) -> np.ndarray:
    """Frames where the gaze (n, 2) speed rises through :data:`SACCADE_DEG_S` (never at the
    first frame of a take: a speed needs the previous frame of the same take)."""
    gaze = np.asarray(gaze, dtype=np.float64)
    fast = np.zeros(len(gaze), bool)
    fast[1:] = np.linalg.norm(np.diff(gaze, axis=0), axis=1) * fps > SACCADE_DEG_S
    fast[list(starts)] = False
    return np.flatnonzero(fast & ~np.concatenate([[False], fast[:-1]]))


@dataclass(frozen=True)
class FixationModel:
    """Saccade intervals and fixation offsets per mode (see the module docstring)."""

    intervals: np.ndarray  # (2, 2) (mu, sigma) of ln(fixation / s), rows talking, listening
    offsets: np.ndarray  # (2, 4) mean yaw, mean pitch, sd yaw, sd pitch (deg), rows as above


def fit_fixation_model(
    gaze: np.ndarray,
    predicted: np.ndarray,
    talking: np.ndarray,
    fps: float,
    starts: Sequence[int] = (0,),
) -> tuple[FixationModel, dict]:
    """Fit the fixation model to ground-truth gaze and the NDCCA gaze ``predicted`` for the
    same frames (both (n, 2), degrees); returns it and a JSON-able summary."""
    residual = np.asarray(gaze, dtype=np.float64) - predicted
    talking = np.asarray(talking, dtype=bool)
    onsets = saccade_onsets(gaze, fps, starts)
    params, sources, counts = fit_interval_params(onsets, talking, fps, starts, DEFAULT_FIXATION)
    # A fixation runs from a take start or a saccade (plus two frames of movement) to the
    # next; its offset is its mean residual, its mode that of its first frame.
    bounds = np.unique(np.concatenate([onsets, list(starts), [len(residual)]]))
    saccades = set(onsets.tolist())
    means, modes = [], []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        first = a + 2 if a in saccades else a
        if b - first >= 2:
            means.append(residual[first:b].mean(axis=0))
            modes.append(bool(talking[a]))
    means_a, modes_a = np.array(means).reshape(-1, 2), np.array(modes, bool)
    offsets = np.zeros((2, 4))
    for i, sel in enumerate((modes_a, ~modes_a)):
        use = means_a[sel] if sel.sum() >= 2 else means_a
        if len(use) >= 2:
            offsets[i] = np.r_[use.mean(axis=0), use.std(axis=0)]
    return (
        FixationModel(params, offsets),
        {"saccades": int(len(onsets)), "interval_source": sources, "intervals": counts},
    )


@dataclass
class FixationClock(IntervalClock):
    """Streaming fixation offsets: a new offset from the mode's normal at each saccade."""

    offsets: np.ndarray = field(default_factory=lambda: np.zeros((2, 4)))
    current: np.ndarray | None = None

    def _draw(self, talking: bool) -> np.ndarray:
        row = self.offsets[0 if talking else 1]
        return row[:2] + row[2:] * self.rng.standard_normal(2)

    def step(self, time: float, talking: bool) -> np.ndarray:
        """The fixation offset (yaw, pitch; degrees) at ``time`` in the current mode."""
        if self.current is None:
            self.current = self._draw(talking)
        for _ in self.onsets(time, talking):
            self.current = self._draw(talking)
        return self.current
