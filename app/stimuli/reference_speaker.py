"""The SYNTHETIC reference speaker: plausible, speech-correlated face motion for any recording.

Where no motion was captured with a recording, facepair makes a ground-truth stand-in from the
speech itself, so the whole pipeline (conditions, rendering, studies) can run and be tested. It
is synthetic and labelled so wherever it appears (``track.source``, the .fap comment lines,
``summary.json``); it is not a model of any real person. Its behaviour follows the visual
prosody literature summarised in thesis sec. 2.3 and 4.3 and Le, Ma & Deng (2012):

- **Talking vs silent** per frame from intensity: above the noise floor (10th percentile) by
  ``talk_fraction`` of the range to the speech level (90th percentile), gaps < 0.3 s closed and
  bursts < 0.1 s dropped.
- **Pitch accents**: prominent peaks of the 3-frame-smoothed conditioned F0 in voiced, talking
  frames (prominence >= max(8 Hz, 0.6 x std of voiced F0), >= 0.4 s apart); strength = the
  peak's z-score against the speaker's voiced F0, clipped to [0.3, 2.5].
- **Head** (FAP 48-50, AU): a nod (pitch down) after each accent (gamma pulse, peak 100 ms
  after the accent, ``nod_au`` x strength); a roll tilt at each accent with random sign; a
  speech-driven part that is a causal first-order response (time constant 0.5 s) to the
  intensity, conditioned F0 and their centred 1-s means, each standardised over the whole
  recording (so per speaker) - the ARX-like structure a learner can recover; slow posture
  drift (Ornstein-Uhlenbeck, time constants 4-8 s); a yaw turn at each talk onset; small
  AR(1) jitter.
- **Eyebrows** (FAP 31-34, ENS): a raise at accents of strength >= 1 (rise 100 ms, hold 250 ms
  + 100 ms per unit strength, fall 200 ms), inner ``brow_ens`` x strength (20 to 50 units),
  middle 0.8x; left = right; the outer eyebrows stay neutral, as the thesis captured none.
  Amplitudes in the range of the thesis' captured speakers (Table 2: inner eyebrow sd 11.8
  and 12.8, mean 5.5 and 6.6 for S2 and S7).
- **Gaze** (FAP 23-26, AU): fixations changing by saccades (2 frames), log-normal fixation
  times (median 1.2 s talking, 2.5 s silent); while talking the speaker looks away (yaw sd 6
  deg, pitch 2 deg down, sd 3 deg), while silent near the listener (sd 1.5 deg); eyes
  counter-rotate 70 % of the head's motion (vestibulo-ocular reflex). Both eyes alike.
- **Blinks** (FAP 19-22, IRISD): log-normal inter-blink intervals (sigma 0.6), median 2.0 s
  while talking and 3.5 s while silent (about 25 vs 14 blinks a minute), decided by the state at
  the previous blink; closing 75 ms, opening 150 ms; upper lids 0.8 and lower lids 0.2 of the
  iris diameter, so the lids meet.
- **Jaw and lips** (FAP 3-5, 51-52, MNS): from the 3-frame-smoothed intensity above the floor.

Versions (``synthesize_reference(..., version=)``; they differ in the head only, and so in the
gaze through its counter-rotation of the head):

- **1** (the default; the shipped demo ground truth and the default models were made with it):
  the speech-driven part of the head (:func:`head_speech_part`: the response and, for pitch,
  the nods) has a standard deviation of about 0.83, 0.67 and 0.13 deg against the whole
  head's 1.44, 3.08 and 0.95 deg (pitch, yaw, roll; the demo speech in the voices of
  :mod:`app.stimuli.live.corpus`, 7 takes of 120 s): speech drives 33 %, 5 % and 2 % of the
  variance. The rest (posture drift, turns, tilts of random sign, jitter) is unrelated to what
  is said, so even a model that knew the speech-driven part exactly would correlate with the
  held-out truth at about 0.6 (pitch), 0.17 (yaw) and 0.0 (roll) - and a generator with the
  truth's amplitude at about the square of that (0.36, 0.03, 0.00). Yaw and roll carry no
  speech relation that a held-out evaluation could show (measured: docs/reference/live.md,
  "Held-out speakers").
- **2**: the same structure with each angle's standard deviation (v1's, in the range of the
  thesis' captured speakers) split evenly between the speech-driven part and the rest: the
  speech-driven part x 1.2, 3.3 and 5.0 (:data:`V2_SPEECH_GAIN`), everything else x 0.9,
  0.7 and 0.7 (:data:`V2_OTHER_GAIN`), so speech drives about half of each angle's variance
  (the knowing model's held-out correlation about 0.7). A design figure for a synthetic
  speaker, between v1's near-absent coupling and a head that is all speech; the visual-prosody
  literature finds head motion substantially but far from fully predictable from prosody.
  The factors follow from the variance shares above, not from any model's results; the live
  model's held-out evaluation uses this version.

Everything is vectorised per component; events (accents, blinks, saccades) are few. The output
is deterministic for a seed. ``track.metadata`` lists the accent, eyebrow-raise and blink
frames, so later tests can check detectors against known events.

Example
-------
>>> import numpy as np
>>> from app.stimuli.speech import SpeechFeatures
>>> n = 90; f0 = np.where(np.arange(n) % 30 < 20, 120.0, 0.0)
>>> feats = SpeechFeatures(30.0, f0, np.where(f0 > 0, 70.0, 40.0), np.full(n, 120.0))
>>> t = synthesize_reference(feats, seed=1)
>>> "synthetic" in t.source, t.n_frames, 48 in t and 19 in t and 23 in t
(True, 90, True)
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import ndimage, signal

from app.stimuli.fap import AU_RADIANS, EYEBROW_RAISE
from app.stimuli.speech import SpeechFeatures, smooth_1s, smooth_3
from app.stimuli.track import MotionTrack

SOURCE = "synthetic reference speaker (facepair; not a recording)"
SPEAKER = "synthetic reference speaker"
_DEG = np.pi / 180 / AU_RADIANS  # AU per degree
#: The reference speaker's versions (module docstring, "Versions"); 1 is the default.
VERSIONS = (1, 2)
#: Version 2: factors of the head's speech-driven part (response and nods) for pitch, yaw, roll.
V2_SPEECH_GAIN = (1.2, 3.3, 5.0)
#: Version 2: factors of the head's speech-independent parts (posture drift, turns at talk
#: onsets, roll tilts of random sign, jitter) for pitch, yaw, roll.
V2_OTHER_GAIN = (0.9, 0.7, 0.7)


def synthesize_reference(
    features: SpeechFeatures,
    *,
    seed: int = 0,
    nod_au: float = 2500.0,
    brow_ens: float = 20.0,
    talk_fraction: float = 0.35,
    version: int = 1,
) -> MotionTrack:
    """The synthetic reference speaker's motion for ``features`` (see the module docstring).

    ``version`` 1 (the default) or 2, whose head carries a learnable speech relation in all
    three angles (module docstring, "Versions"); they differ in the head only (and the gaze,
    which counter-rotates it).
    """
    if version not in VERSIONS:
        raise ValueError(f"reference speaker version must be one of {VERSIONS}, got {version!r}")
    n, fps = features.n_frames, features.fps
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(6)]
    talking = talking_frames(features.intensity, fps, talk_fraction)
    accents, strength = pitch_accents(features, talking)

    head = _head(features, talking, accents, strength, nod_au, rngs[0], version)
    brows, raises = _eyebrows(n, fps, accents, strength, brow_ens)
    gaze = _gaze(n, fps, talking, head, rngs[1])
    lids, blinks = _blinks(n, fps, talking, rngs[2])
    mouth = _jaw_lips(features.intensity, talking)

    columns = {**head, **brows, **gaze, **lids, **mouth}
    meta: dict[str, Any] = {
        "synthetic": True,
        "model": f"facepair synthetic reference speaker v{version}",
        "seed": seed,
        "accent_frames": accents.tolist(),
        "eyebrow_raise_frames": raises,
        "blink_frames": blinks,
        "talking_fraction": float(talking.mean()) if n else 0.0,
    }
    return MotionTrack.from_channels(
        fps, columns, name="GROUND_TRUTH (synthetic)", source=SOURCE, speaker=SPEAKER, metadata=meta
    )


def talking_frames(intensity: np.ndarray, fps: float, talk_fraction: float = 0.35) -> np.ndarray:
    """Boolean mask of frames where the speaker talks, decided from intensity (dB)."""
    x = np.asarray(intensity, dtype=np.float64)
    if len(x) == 0:
        return np.zeros(0, dtype=bool)
    floor, level = np.percentile(x, [10, 90])
    mask = smooth_3(x) > floor + talk_fraction * max(level - floor, 1e-9)
    close = max(round(0.3 * fps), 1)
    opening = max(round(0.1 * fps), 1)
    padded = np.pad(mask, close, mode="edge")
    mask = ndimage.binary_closing(padded, np.ones(close, dtype=bool))[close:-close]
    return ndimage.binary_opening(mask, np.ones(opening, dtype=bool))


def pitch_accents(features: SpeechFeatures, talking: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frames of pitch accents and their strengths (z-scores clipped to [0.3, 2.5])."""
    voiced = features.voiced & talking
    if voiced.sum() < 3:
        return np.zeros(0, dtype=int), np.zeros(0)
    f0 = smooth_3(features.f0_conditioned)
    ref = features.f0[voiced]
    sd = max(float(ref.std()), 1.0)
    prominence = max(8.0, 0.6 * sd)
    peaks, _ = signal.find_peaks(
        np.where(voiced, f0, 0.0), prominence=prominence, distance=max(round(0.4 * features.fps), 1)
    )
    peaks = peaks[voiced[peaks]]
    strength = np.clip((f0[peaks] - np.median(ref)) / sd + 1.0, 0.3, 2.5)
    return peaks.astype(int), strength


def _pulses(n: int, frames: np.ndarray, weights: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Sum of ``kernel`` copies starting at ``frames`` scaled by ``weights``."""
    train = np.zeros(n)
    np.add.at(train, frames, weights)
    return signal.fftconvolve(train, kernel)[:n] if n else train


def _ou(n: int, fps: float, tau: float, sd: float, rng: np.random.Generator) -> np.ndarray:
    """Ornstein-Uhlenbeck process (stationary from the first frame)."""
    a = np.exp(-1.0 / (tau * fps))
    e = rng.standard_normal(n) * sd * np.sqrt(1 - a * a)
    if n:
        e[0] = rng.standard_normal() * sd
    return signal.lfilter([1.0], [1.0, -a], e)


def _standard(x: np.ndarray) -> np.ndarray:
    if len(x) == 0:
        return np.zeros(0)
    sd = x.std()
    return (x - x.mean()) / sd if sd > 0 else np.zeros_like(x)


def head_speech_part(
    features: SpeechFeatures,
    *,
    nod_au: float = 2500.0,
    talk_fraction: float = 0.35,
    version: int = 1,
) -> dict[int, np.ndarray]:
    """The part of the reference speaker's head (FAP 48-50, AU) that the speech drives: the
    first-order response to the standardised speech contours, and for pitch the nods at
    accents. The rest of the head (posture drift, turns at talk onsets, roll tilts of random
    sign, jitter) does not depend on what is said. This is the most any speech-driven model
    can recover: held-out figures compare with it (docs/reference/live.md)."""
    talking = talking_frames(features.intensity, features.fps, talk_fraction)
    accents, strength = pitch_accents(features, talking)
    parts = _speech_drive(features, accents, strength, nod_au, version)
    return {48: parts[0], 49: parts[1], 50: parts[2]}


def _speech_drive(
    features: SpeechFeatures,
    accents: np.ndarray,
    strength: np.ndarray,
    nod_au: float,
    version: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(pitch, yaw, roll) speech-driven parts, AU, scaled for ``version``."""
    n, fps = features.n_frames, features.fps
    gs = V2_SPEECH_GAIN if version == 2 else (1.0,) * 3
    nods = _pulses(n, accents, nod_au * strength, _gamma(fps))
    inten = _standard(features.intensity)
    f0 = _standard(features.f0_conditioned)
    inten_1s, f0_1s = (
        _standard(smooth_1s(features.intensity, fps)),
        _standard(smooth_1s(features.f0_conditioned, fps)),
    )
    a = np.exp(-1.0 / (0.5 * fps))
    respond = lambda x: signal.lfilter([1 - a], [1.0, -a], x)  # noqa: E731
    # positive pitch is down: loud, high speech lifts the head a little
    pitch = respond(-900.0 * inten - 600.0 * f0 - 500.0 * inten_1s) * gs[0] + nods * gs[0]
    yaw = respond(700.0 * f0 + 900.0 * f0_1s - 400.0 * inten) * gs[1]
    roll = respond(-500.0 * f0 + 400.0 * inten_1s) * gs[2]
    return pitch, yaw, roll


def _gamma(fps: float) -> np.ndarray:
    """The nod and tilt pulse: a gamma shape peaking at 1 after 0.1 s, 1 s long."""
    t = np.arange(max(round(1.0 * fps), 2)) / fps
    tau = 0.1
    return (t / tau) * np.exp(1 - t / tau)


def _head(
    features: SpeechFeatures,
    talking: np.ndarray,
    accents: np.ndarray,
    strength: np.ndarray,
    nod_au: float,
    rng: np.random.Generator,
    version: int = 1,
) -> dict[int, np.ndarray]:
    n, fps = features.n_frames, features.fps
    # factors (pitch, yaw, roll) of the speech-independent parts; 1.0 in v1, so that v1's values
    # are exactly those of the code before versions existed
    go = V2_OTHER_GAIN if version == 2 else (1.0,) * 3
    roll_tilt = _pulses(
        n, accents, 0.5 * nod_au * strength * rng.choice([-1.0, 1.0], len(accents)), _gamma(fps)
    )
    pitch, yaw, roll = _speech_drive(features, accents, strength, nod_au, version)
    roll = roll + roll_tilt * go[2]
    onsets = np.flatnonzero(np.diff(talking.astype(int)) == 1) + 1
    turn = np.repeat(
        np.r_[0.0, rng.normal(0, 2.5 * _DEG, len(onsets))], np.diff(np.r_[0, onsets, n])
    )
    yaw += ndimage.uniform_filter1d(turn, max(round(0.4 * fps), 1), mode="nearest") * go[1]
    pitch += _ou(n, fps, 4.0, 1.2 * _DEG, rng) * go[0]
    yaw += _ou(n, fps, 6.0, 2.0 * _DEG, rng) * go[1]
    roll += _ou(n, fps, 8.0, 0.8 * _DEG, rng) * go[2]
    for x, g in zip((pitch, yaw, roll), go, strict=True):
        x += _ou(n, fps, 0.1, 0.15 * _DEG, rng) * g
    return {48: pitch, 49: yaw, 50: roll}


def _eyebrows(
    n: int, fps: float, accents: np.ndarray, strength: np.ndarray, brow_ens: float
) -> tuple[dict[int, np.ndarray], list[int]]:
    inner = np.zeros(n)
    chosen = accents[strength >= 1.0]
    rise, fall = max(round(0.1 * fps), 1), max(round(0.2 * fps), 1)
    for k, s in zip(chosen, strength[strength >= 1.0], strict=True):
        hold = round((0.25 + 0.1 * s) * fps)
        shape = (
            np.r_[np.linspace(0, 1, rise + 1)[1:], np.ones(hold), np.linspace(1, 0, fall + 1)[1:]]
            * brow_ens
            * s
        )
        start = max(int(k) - rise // 2, 0)
        seg = shape[: n - start]
        inner[start : start + len(seg)] = np.maximum(inner[start : start + len(seg)], seg)
    ratio = {31: 1.0, 32: 1.0, 33: 0.8, 34: 0.8, 35: 0.0, 36: 0.0}
    assert tuple(ratio) == EYEBROW_RAISE
    return {c: r * inner for c, r in ratio.items()}, [int(k) for k in chosen]


def _state_intervals(
    n: int,
    fps: float,
    talking: np.ndarray,
    rng: np.random.Generator,
    median_talk: float,
    median_silent: float,
    sigma: float,
) -> np.ndarray:
    """Event frames with log-normal intervals whose median depends on talking at the last event.

    Draws are made in bulk for both states and consumed in order, so the loop only walks the
    few events.
    """
    if n == 0:
        return np.zeros(0, dtype=int)
    budget = int(n / fps / min(median_talk, median_silent) * 3) + 8
    draws = {
        True: rng.lognormal(np.log(median_talk), sigma, budget),
        False: rng.lognormal(np.log(median_silent), sigma, budget),
    }
    used = {True: 0, False: 0}
    frames = []
    t = float(rng.uniform(0, median_silent))
    while t * fps < n:
        k = int(t * fps)
        frames.append(k)
        state = bool(talking[k])
        if used[state] >= budget:
            break
        t += max(float(draws[state][used[state]]), 0.25)
        used[state] += 1
    return np.array(frames, dtype=int)


def _gaze(
    n: int, fps: float, talking: np.ndarray, head: dict[int, np.ndarray], rng: np.random.Generator
) -> dict[int, np.ndarray]:
    shifts = _state_intervals(n, fps, talking, rng, 1.2, 2.5, 0.5)
    if len(shifts) == 0:
        return {c: np.zeros(n) for c in (23, 24, 25, 26)}
    away = talking[shifts]
    yaw_t = np.where(away, rng.normal(0, 6.0, len(shifts)), rng.normal(0, 1.5, len(shifts)))
    pitch_t = np.where(away, rng.normal(2.0, 3.0, len(shifts)), rng.normal(0, 1.5, len(shifts)))
    lengths = np.diff(np.r_[shifts, n])
    yaw = np.r_[np.zeros(shifts[0]), np.repeat(yaw_t, lengths)] * _DEG
    pitch = np.r_[np.zeros(shifts[0]), np.repeat(pitch_t, lengths)] * _DEG
    yaw = ndimage.uniform_filter1d(yaw, 2, mode="nearest") - 0.7 * _centre(head[49], fps)
    pitch = ndimage.uniform_filter1d(pitch, 2, mode="nearest") - 0.7 * _centre(head[48], fps)
    return {23: yaw, 24: yaw.copy(), 25: pitch, 26: pitch.copy()}


def _centre(x: np.ndarray, fps: float) -> np.ndarray:
    """Head motion around its 2-s mean: the part the eyes compensate."""
    return x - ndimage.uniform_filter1d(x, max(round(2 * fps), 1), mode="nearest")


def _blinks(
    n: int, fps: float, talking: np.ndarray, rng: np.random.Generator
) -> tuple[dict[int, np.ndarray], list[int]]:
    onsets = _state_intervals(n, fps, talking, rng, 2.0, 3.5, 0.6)
    close, opening = max(round(0.075 * fps), 1), max(round(0.15 * fps), 1)
    shape = np.r_[np.linspace(0, 1, close + 1)[1:], np.linspace(1, 0, opening + 1)[1:]]
    closure = np.minimum(_pulses(n, onsets, np.ones(len(onsets)), shape), 1.0)
    upper, lower = 0.8 * 1024 * closure, 0.2 * 1024 * closure
    return {19: upper, 20: upper.copy(), 21: lower, 22: lower.copy()}, onsets.tolist()


def _jaw_lips(intensity: np.ndarray, talking: np.ndarray) -> dict[int, np.ndarray]:
    x = smooth_3(np.asarray(intensity, dtype=np.float64))
    if len(x) == 0:
        return {c: np.zeros(0) for c in (3, 4, 5, 51, 52)}
    floor, level = np.percentile(x, [10, 95])
    opening = np.clip((x - floor) / max(level - floor, 1e-9), 0, 1) * talking
    return {
        3: 350.0 * opening,
        4: -40.0 * opening,
        5: -40.0 * opening,
        51: -40.0 * opening,
        52: -40.0 * opening,
    }
