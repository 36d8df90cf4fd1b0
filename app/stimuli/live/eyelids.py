"""Eyelid motion: gaze-evoked lid motion plus involuntary blinks (Le, Ma & Deng 2012, sec. 7).

Openness ``o`` runs from 0 (closed) to 1 (the neutral, open lid). On the face it is written as
lid closure ``1 - o`` in FAPs 19-22 (IRISD units; the neutral upper-to-lower lid distance is 1024
IRISD): ``top_share`` of the closure on the upper lids (19, 20), the rest on the lower lids
(21, 22), the same for both eyes. ``top_share`` is learned from the ground truth (default 0.8).

Gaze-evoked motion (sec. 7.2-7.3, eq. 17-18): ``b_t = Cb x_t`` with ``Cb >= 0`` found by
non-negative least squares (``scipy.optimize.nnls``) on the ground truth's non-blink frames.
``x_t = (gaze up, |gaze yaw|, 1)`` in degrees. Eq. 17-18 read literally (``b = Cb e`` over the
signed gaze angles, ``Cb >= 0``) would open the lids when the eyes turn one way and close them
when they turn the other, and tie the lids to the FAP sign convention of the pitch axis. The
paper's own reading (sec. 7.2, after Evinger et al.: the lid moves with the gaze and "its
magnitude often increases in accordance with the amplitude of the eye gaze") fixes both: the
upper lid follows vertical gaze (looking up opens, looking down lowers the lid: the pitch axis
is turned so that this coupling is the non-negative one), and horizontal gaze acts through its
amplitude ``|yaw|`` only, the same to the left and to the right. The constant column is the
neutral openness, which eq. 17 leaves implicit.

Involuntary blinks (sec. 7.1, eq. 16, 19): inter-blink intervals ``L`` with ``ln L ~ N(mu,
sigma^2)``, one (mu, sigma) for the talking mode and one for listening, fitted by maximum
likelihood to the ground truth's blink onsets when it has at least :data:`MIN_INTERVALS` of a
mode, otherwise the defaults below. The paper's fitted figures (21.1 +/- 3.6 talking, 15.4 +/-
3.9 listening) are read as blinks per minute: the default mean intervals are 60/21.1 s and
60/15.4 s, with ``sigma = 0.5`` (about 50 % coefficient of variation, typical of spontaneous
blinking). When a blink starts, the next interval is drawn from the mode of that moment.

Blink shape (documented choice; the paper gives none): closure fraction rising as a half cosine
over 100 ms, fully closed for 50 ms, reopening as a half cosine over 250 ms (reopening is slower
than closing). Openness during a blink is ``b_t (1 - s(tau))``: the paper's sum of voluntary and
involuntary motion, with the blink scaled so that it always closes the lid fully.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import nnls

#: Closure fraction above which a ground-truth frame counts as inside a blink.
BLINK_THRESHOLD = 0.5
#: Fewest intervals of a mode needed to fit its log-normal; fewer: the defaults.
MIN_INTERVALS = 8
#: Default log-normal sigma of the inter-blink interval.
DEFAULT_SIGMA = 0.5
#: Default mean inter-blink intervals in seconds (talking, listening): Le et al. 2012 sec. 7.1.
DEFAULT_MEAN_INTERVAL = (60.0 / 21.1, 60.0 / 15.4)
#: Blink shape: closing, closed, opening durations in seconds.
BLINK_SHAPE = (0.10, 0.05, 0.25)


def default_blink_params() -> np.ndarray:
    """(2, 2) array of (mu, sigma) for (talking, listening), from the defaults above."""
    mu = np.log(np.array(DEFAULT_MEAN_INTERVAL)) - 0.5 * DEFAULT_SIGMA**2
    return np.column_stack([mu, np.full(2, DEFAULT_SIGMA)])


def blink_closure(
    tau: np.ndarray | float, shape: tuple[float, float, float] = BLINK_SHAPE
) -> np.ndarray:
    """Closure fraction (0 open .. 1 closed) ``tau`` seconds after a blink's onset."""
    tc, th, to = shape
    tau = np.asarray(tau, dtype=np.float64)
    out = np.zeros(tau.shape)
    closing = (tau >= 0) & (tau < tc)
    out[closing] = 0.5 * (1.0 - np.cos(np.pi * tau[closing] / tc))
    out[(tau >= tc) & (tau < tc + th)] = 1.0
    opening = (tau >= tc + th) & (tau < tc + th + to)
    out[opening] = 0.5 * (1.0 + np.cos(np.pi * (tau[opening] - tc - th) / to))
    return out


def blink_onsets(closure: np.ndarray) -> np.ndarray:
    """Frame indices where the closure fraction rises through :data:`BLINK_THRESHOLD`."""
    shut = np.asarray(closure) >= BLINK_THRESHOLD
    return np.flatnonzero(shut & ~np.concatenate([[False], shut[:-1]]))


def fit_interval_params(
    onsets: np.ndarray,
    talking: np.ndarray,
    fps: float,
    starts: Sequence[int] = (0,),
    defaults: np.ndarray | None = None,
) -> tuple[np.ndarray, list[str], list[int]]:
    """Maximum-likelihood log-normal (mu, sigma) per mode from event onset frames (blinks
    here, saccades in :mod:`app.stimuli.live.gaze`); ``defaults`` (2, 2) for a mode with too
    few intervals (blinks: :func:`default_blink_params`).

    An interval belongs to the mode of the frame where it starts; intervals spanning two takes
    (``starts``: their first frames) are not intervals. Returns the (2, 2) parameters
    (talking, listening), where each came from ("fitted" or "default") and interval counts.
    """
    params = default_blink_params() if defaults is None else np.array(defaults, dtype=np.float64)
    sources, counts = ["default", "default"], [0, 0]
    onsets = np.asarray(onsets, dtype=int)
    if len(onsets) > 1:
        take = np.searchsorted(np.asarray(starts), onsets, side="right")
        same = take[1:] == take[:-1]
        intervals = (np.diff(onsets) / fps)[same]
        mode_talk = np.asarray(talking, dtype=bool)[onsets[:-1]][same]
        for i, sel in enumerate((mode_talk, ~mode_talk)):
            logs = np.log(intervals[sel])
            counts[i] = int(sel.sum())
            if counts[i] >= MIN_INTERVALS and logs.std() > 1e-6:
                params[i] = (logs.mean(), logs.std())
                sources[i] = "fitted"
    return params, sources, counts


@dataclass(frozen=True)
class EyelidModel:
    """Gaze-evoked lid coefficients and blink parameters."""

    cb: np.ndarray  # (3,) eq. 17 coefficients over (gaze up, |gaze yaw|, 1)
    blink: np.ndarray  # (2, 2) (mu, sigma) of ln(interval / s), rows (talking, listening)
    top_share: float = 0.8
    shape: tuple[float, float, float] = BLINK_SHAPE

    def openness(self, gaze: np.ndarray) -> float:
        """Eq. 18 for one frame's gaze (yaw, pitch-down) in degrees, clipped to [0, 1.5]."""
        b = self.cb[0] * -gaze[1] + self.cb[1] * abs(gaze[0]) + self.cb[2]
        return float(min(max(b, 0.0), 1.5))

    def faps(self, openness: float, closure_fraction: float) -> np.ndarray:
        """FAPs 19-22 (IRISD) for a gaze-evoked openness and a blink closure fraction."""
        closure = (1.0 - openness * (1.0 - closure_fraction)) * 1024.0
        top, bottom = self.top_share * closure, (1.0 - self.top_share) * closure
        return np.array([top, top, bottom, bottom])


def closure_from_faps(lids: np.ndarray) -> tuple[np.ndarray, float]:
    """Ground truth FAPs 19-22 (n, 4) -> closure fraction per frame and the upper-lid share."""
    lids = np.asarray(lids, dtype=np.float64)
    per_eye = np.column_stack([lids[:, 0] + lids[:, 2], lids[:, 1] + lids[:, 3]])
    closure = per_eye.mean(axis=1) / 1024.0
    total = np.abs(lids).sum()
    share = float(np.abs(lids[:, :2]).sum() / total) if total > 0 else 0.8
    return closure, share


def fit_eyelid_model(
    gaze: np.ndarray,
    lids: np.ndarray | None,
    talking: np.ndarray,
    fps: float,
    starts: Sequence[int] = (0,),
) -> tuple[EyelidModel, dict]:
    """Fit eq. 17 and the blink model to ground-truth gaze (n, 2) and FAPs 19-22 (n, 4) (or
    None: defaults); ``starts``: first frames of concatenated takes. Returns the model and a
    JSON-able summary."""
    if lids is None or not np.any(lids):
        params, sources, counts = fit_interval_params(np.array([], int), talking, fps)
        model = EyelidModel(np.array([0.0, 0.0, 1.0]), params)
        return model, {"blink_source": sources, "intervals": counts, "blinks": 0}
    closure, share = closure_from_faps(lids)
    onsets = np.concatenate(
        [
            blink_onsets(closure[a:b]) + a
            for a, b in zip(starts, list(starts[1:]) + [len(closure)], strict=True)
        ]
    )
    params, sources, counts = fit_interval_params(onsets, talking, fps, starts)
    # Frames inside or near a blink do not show gaze-evoked motion: leave them out of eq. 17.
    keep = np.ones(len(closure), bool)
    before, after = int(np.ceil(0.1 * fps)), int(np.ceil(sum(BLINK_SHAPE) * fps))
    for onset in onsets:
        keep[max(0, onset - before) : onset + after] = False
    x = np.column_stack([-gaze[:, 1], np.abs(gaze[:, 0]), np.ones(len(gaze))])[keep]
    cb = nnls(x, 1.0 - closure[keep])[0] if keep.sum() >= 3 else np.array([0.0, 0.0, 1.0])
    model = EyelidModel(cb, params, share)
    return model, {"blink_source": sources, "intervals": counts, "blinks": int(len(onsets))}


@dataclass
class IntervalClock:
    """Streaming onsets of events with log-normal intervals whose (mu, sigma) depend on the
    mode (eq. 19): when an event starts, the next interval is drawn from the mode of that
    moment; the first onset is a uniform fraction of a first interval. No look-ahead."""

    params: np.ndarray  # (2, 2) (mu, sigma) of ln(interval / s), rows (talking, listening)
    rng: np.random.Generator
    next_onset: float | None = None
    log: list[tuple[float, bool, float]] = field(default_factory=list)  # (onset, talking, gap)

    def _interval(self, talking: bool) -> float:
        mu, sigma = self.params[0 if talking else 1]
        return float(np.exp(mu + sigma * self.rng.standard_normal()))  # eq. 19

    def onsets(self, time: float, talking: bool) -> list[float]:
        """Onsets (seconds) up to ``time`` that earlier calls did not return."""
        if self.next_onset is None:
            self.next_onset = time + self.rng.uniform() * self._interval(talking)
        new = []
        while time >= self.next_onset:
            onset = self.next_onset
            gap = self._interval(talking)
            new.append(onset)
            self.log.append((onset, talking, gap))
            self.next_onset = onset + gap
        return new


@dataclass
class BlinkClock(IntervalClock):
    """Streaming blink generator: blink onsets from :class:`IntervalClock`, and the closure
    fraction at each frame time."""

    shape: tuple[float, float, float] = BLINK_SHAPE
    active: list[float] = field(default_factory=list)

    def step(self, time: float, talking: bool) -> float:
        """Closure fraction at ``time`` (seconds), given the current mode."""
        self.active += self.onsets(time, talking)
        total = sum(self.shape)
        self.active = [o for o in self.active if time - o < total]
        if not self.active:
            return 0.0
        return float(blink_closure(np.array([time - o for o in self.active]), self.shape).max())
