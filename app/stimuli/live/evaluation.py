"""Held-out evaluation of the live generator against a ground truth's motion statistics.

Le, Ma & Deng 2012 judge their generator by paired comparisons with the captured motion (sec.
8.1); before any study, the generated motion should at least move like the ground truth. This
module measures, on speech the model was not trained on, per channel:

- the standard deviation of the generated motion and its ratio to the ground truth's (head
  pitch, yaw, roll and gaze yaw, pitch; degrees);
- the share of the variance above 4 Hz (:func:`high_frequency_fraction`): jitter that a head
  or a fixating eye does not have;
- the Pearson correlation with the ground truth (the speech-driven part it can recover);
- the blink rate (blinks per minute, onsets of the lid closure through 50 %).

:func:`held_out_split` makes the explicit split: training takes in the training voices of
:mod:`app.stimuli.live.corpus` with the reference speaker's motion of some seeds, test takes in
the test voices with other seeds; :func:`evaluate_held_out` generates on the test takes only.
:func:`speaker_split` makes test takes of one held-out voice each (a held-out *speaker*), for
:func:`head_agreement` (correlation and canonical correlation with the truth, and the ratios of
eq. 1's kinematics) and :func:`stratified_bootstrap` (intervals over takes and seeds), which
``benchmarks/bench_live_speech.py`` reports.

Example
-------
>>> import numpy as np
>>> t = np.arange(300) / 30.0
>>> round(high_frequency_fraction(np.sin(2 * np.pi * t) + np.sin(2 * np.pi * 6 * t), 30.0), 3)
0.5
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import parselmouth

from app.stimuli.live.corpus import TEST_VOICES, TRAIN_VOICES, speech_take
from app.stimuli.live.eyelids import blink_onsets, closure_from_faps
from app.stimuli.live.head import kinematic_features
from app.stimuli.live.model import LiveModel, gaze_angles, head_angles
from app.stimuli.live.stream import generate_track
from app.stimuli.measures import canonical_correlations
from app.stimuli.reference_speaker import synthesize_reference
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack

#: Channels measured, in the order of :attr:`HeldOutFigures.sd` etc.
CHANNELS = ("head pitch", "head yaw", "head roll", "gaze yaw", "gaze pitch")
#: Frequency above which motion counts as jitter (Hz).
JITTER_HZ = 4.0


def high_frequency_fraction(x: np.ndarray, fps: float, cutoff_hz: float = JITTER_HZ) -> float:
    """Share of the variance of ``x`` (a signal sampled at ``fps``) above ``cutoff_hz``: the
    periodogram of the mean-removed signal summed above the cutoff over its sum above 0 Hz
    (0 for a constant signal)."""
    x = np.asarray(x, dtype=np.float64)
    power = np.abs(np.fft.rfft(x - x.mean())) ** 2
    freqs = np.fft.rfftfreq(len(x), 1.0 / fps)
    total = power[freqs > 0].sum()
    return float(power[freqs > cutoff_hz].sum() / total) if total > 0 else 0.0


def blink_rate(track: MotionTrack) -> float:
    """Blinks per minute in ``track``'s eyelids (FAPs 19-22): onsets of closure through 50 %."""
    closure, _ = closure_from_faps(track.dense()[:, [18, 19, 20, 21]])
    return 60.0 * len(blink_onsets(closure)) / track.duration if track.n_frames else 0.0


def motion_channels(track: MotionTrack) -> np.ndarray:
    """(n, 5) head pitch, yaw, roll and gaze yaw, pitch in degrees (see :data:`CHANNELS`)."""
    yaw, pitch, roll = head_angles(track).T
    return np.column_stack([pitch, yaw, roll, gaze_angles(track)])


@dataclass(frozen=True)
class HeldOutFigures:
    """Figures per channel of :data:`CHANNELS` (means over test takes and generation seeds)."""

    sd: np.ndarray  # generated sd, degrees
    sd_truth: np.ndarray  # ground truth sd, degrees
    jitter: np.ndarray  # generated share of variance above JITTER_HZ
    jitter_truth: np.ndarray
    correlation: np.ndarray  # Pearson r, generated vs ground truth
    blinks_per_min: float
    blinks_per_min_truth: float

    @property
    def sd_ratio(self) -> np.ndarray:
        return self.sd / np.where(self.sd_truth > 0, self.sd_truth, np.nan)

    def table(self) -> str:
        """The figures as a plain-text table."""
        rows = [
            f"{'channel':<11} {'sd':>6} {'truth':>6} {'ratio':>6} {'>4Hz':>6} {'truth':>6} {'r':>6}"
        ]
        for i, name in enumerate(CHANNELS):
            rows.append(
                f"{name:<11} {self.sd[i]:6.2f} {self.sd_truth[i]:6.2f} "
                f"{self.sd_ratio[i]:6.2f} {self.jitter[i]:6.3f} "
                f"{self.jitter_truth[i]:6.3f} {self.correlation[i]:6.2f}"
            )
        rows.append(f"blinks/min  {self.blinks_per_min:6.1f} {self.blinks_per_min_truth:6.1f}")
        return "\n".join(rows)


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    if a.std() == 0 or b.std() == 0:
        return 0.0
    return float(np.corrcoef(a, b)[0, 1])


def compare_motion(generated: MotionTrack, truth: MotionTrack) -> HeldOutFigures:
    """Figures of one generated track against the ground truth of the same speech."""
    n = min(generated.n_frames, truth.n_frames)
    g, t = motion_channels(generated)[:n], motion_channels(truth)[:n]
    fps = generated.fps
    return HeldOutFigures(
        g.std(axis=0),
        t.std(axis=0),
        np.array([high_frequency_fraction(g[:, i], fps) for i in range(5)]),
        np.array([high_frequency_fraction(t[:, i], fps) for i in range(5)]),
        np.array([_corr(g[:, i], t[:, i]) for i in range(5)]),
        blink_rate(generated),
        blink_rate(truth),
    )


def mean_figures(figures: Sequence[HeldOutFigures]) -> HeldOutFigures:
    """Average of several comparisons (each take and seed weighs the same)."""

    def avg(name: str) -> np.ndarray:
        return np.mean([getattr(f, name) for f in figures], axis=0)

    return HeldOutFigures(
        avg("sd"),
        avg("sd_truth"),
        avg("jitter"),
        avg("jitter_truth"),
        avg("correlation"),
        float(avg("blinks_per_min")),
        float(avg("blinks_per_min_truth")),
    )


def evaluate_held_out(
    model: LiveModel,
    takes: Sequence[tuple[SpeechFeatures, MotionTrack]],
    seeds: Sequence[int] = (0, 1),
    **options: Any,
) -> HeldOutFigures:
    """Generate on every test take with every seed and compare with its ground truth;
    ``options`` go to :func:`app.stimuli.live.stream.generate_track`."""
    return mean_figures(
        [
            compare_motion(generate_track(model, feats, seed=s, **options), truth)
            for feats, truth in takes
            for s in seeds
        ]
    )


@dataclass(frozen=True)
class HeldOutSplit:
    """Training and test takes, (features, ground truth) each; no take is in both."""

    train: list[tuple[SpeechFeatures, MotionTrack]]
    test: list[tuple[SpeechFeatures, MotionTrack]]


def held_out_split(
    sound: parselmouth.Sound,
    *,
    train_takes: int = 3,
    test_takes: int = 4,
    seconds: float = 120.0,
    fps: float = 30.0,
    reference_version: int = 1,
) -> HeldOutSplit:
    """The standard split on one recording: training takes ``0 .. train_takes-1`` in
    :data:`~app.stimuli.live.corpus.TRAIN_VOICES` with reference-speaker seeds equal to the take
    number; test takes in :data:`~app.stimuli.live.corpus.TEST_VOICES` with take and speaker
    seeds from 100 on. Every take is ``seconds`` long; the motion is the reference speaker's
    ``reference_version``."""

    def takes(voices: tuple, first: int, count: int) -> list:
        out = []
        for i in range(first, first + count):
            feats = speech_take(sound, voices, seconds, seed=i, fps=fps)
            out.append((feats, synthesize_reference(feats, seed=i, version=reference_version)))
        return out

    return HeldOutSplit(takes(TRAIN_VOICES, 0, train_takes), takes(TEST_VOICES, 100, test_takes))


def speaker_split(
    sound: parselmouth.Sound,
    *,
    train_takes: int = 3,
    train_seconds: float = 120.0,
    takes_per_voice: int = 3,
    seconds: float = 60.0,
    fps: float = 30.0,
    reference_version: int = 2,
) -> HeldOutSplit:
    """Held-out *speakers*: training takes as :func:`held_out_split`'s (the training voices
    mixed, seeds ``0 .. train_takes-1``); then, for each voice ``v`` of
    :data:`~app.stimuli.live.corpus.TEST_VOICES`, ``takes_per_voice`` takes in that voice
    alone with take and reference seeds ``100 + 10 v + k``. A test take's features carry
    ``metadata["voice"]`` (its index in TEST_VOICES)."""
    train = []
    for i in range(train_takes):
        feats = speech_take(sound, TRAIN_VOICES, train_seconds, seed=i, fps=fps)
        train.append((feats, synthesize_reference(feats, seed=i, version=reference_version)))
    test = []
    for v, voice in enumerate(TEST_VOICES):
        for k in range(takes_per_voice):
            seed = 100 + 10 * v + k
            feats = speech_take(sound, (voice,), seconds, seed=seed, fps=fps)
            feats.metadata["voice"] = v
            test.append((feats, synthesize_reference(feats, seed=seed, version=reference_version)))
    return HeldOutSplit(train, test)


def head_pose(track: MotionTrack) -> np.ndarray:
    """(n, 3) head pitch, yaw, roll in degrees (the order of :data:`CHANNELS`)."""
    yaw, pitch, roll = head_angles(track).T
    return np.column_stack([pitch, yaw, roll])


def head_agreement(generated: np.ndarray, truth: np.ndarray, fps: float) -> dict[str, np.ndarray]:
    """How a generated head (n, 3) agrees with the truth's (n, 3), both (pitch, yaw, roll) in
    degrees: ``r`` (3,) Pearson correlation per angle; ``cc`` the first canonical correlation
    between the two triples; ``kinematics`` (5,) the generated motion's sd of pitch, yaw, roll,
    mean angular speed and mean angular acceleration (eq. 1) over the truth's (1: as the truth).

    >>> t = np.linspace(0, 20, 600)[:, None] * np.array([1.0, 0.7, 0.3])
    >>> truth = np.sin(t)
    >>> m = head_agreement(2 * truth, truth, 30.0)
    >>> m["r"].round(6).tolist(), round(float(m["cc"]), 6), m["kinematics"].round(6).tolist()
    ([1.0, 1.0, 1.0], 1.0, [2.0, 2.0, 2.0, 2.0, 2.0])
    """
    n = min(len(generated), len(truth))
    g, t = np.asarray(generated, float)[:n], np.asarray(truth, float)[:n]
    r = np.array([_corr(g[:, i], t[:, i]) for i in range(3)])
    cc = canonical_correlations(g, t)
    kin_g = kinematic_features(g, fps)
    kin_t = kinematic_features(t, fps)

    def summary(x: np.ndarray, k: np.ndarray) -> np.ndarray:
        return np.r_[x.std(axis=0), np.nanmean(k[:, 3]), np.nanmean(k[:, 4])]

    ref = summary(t, kin_t)
    ratio = summary(g, kin_g) / np.where(ref > 0, ref, np.nan)
    return {"r": r, "cc": np.array(cc[0] if cc else 0.0), "kinematics": ratio}


def stratified_bootstrap(
    values: np.ndarray,
    strata: Sequence[int],
    *,
    n_boot: int = 2000,
    seed: int = 0,
    level: float = 0.95,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean and percentile-bootstrap interval of ``values`` (takes, seeds, ...) over takes and
    generation seeds: each resample draws, within each stratum (a held-out voice), as many
    takes as it has, with replacement, and within each drawn take as many seeds, with
    replacement; the statistic is the mean over everything drawn. Returns (mean, low, high),
    each of the shape of one value.

    >>> v = np.arange(8.0).reshape(4, 2)  # 4 takes x 2 seeds
    >>> m, lo, hi = stratified_bootstrap(v, [0, 0, 1, 1], n_boot=500)
    >>> float(m), bool(lo < m < hi)
    (3.5, True)
    """
    values = np.asarray(values, dtype=np.float64)
    labels = np.asarray(strata)
    rng = np.random.default_rng(seed)
    n_takes, n_seeds = values.shape[0], values.shape[1]
    groups = [np.flatnonzero(labels == s) for s in np.unique(labels)]
    stats = np.empty((n_boot,) + values.shape[2:])
    for b in range(n_boot):
        takes = np.concatenate([rng.choice(g, len(g)) for g in groups])
        seeds = rng.integers(0, n_seeds, (len(takes), n_seeds))
        stats[b] = values[takes[:, None], seeds].mean(axis=(0, 1))
    alpha = (1.0 - level) / 2.0
    low, high = np.quantile(stats, [alpha, 1.0 - alpha], axis=0)
    assert n_takes == len(labels)
    return values.mean(axis=(0, 1)), low, high
