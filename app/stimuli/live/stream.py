"""The streaming head-and-eye generator: one frame of speech in, one frame of motion out.

The three modules run in the paper's chain (Le, Ma & Deng 2012, sec. 3, Fig. 1): the head
(sec. 5) from the frame's pitch and loudness, standardised per speaker
(:class:`app.stimuli.live.inputs.SpeakerNorm`): by default the angle GMMs' expectation,
aligned, plus the variation speech does not predict (:mod:`app.stimuli.live.expectation`;
``synthesis="langevin"``: the earlier per-frame draw from eq. 3 near the two previous poses);
the gaze (sec. 6) from the new pose and the loudness; the eyelids (sec. 7) from the new gaze
and the mode. Only the current and past input is read. The offline path (:meth:`LiveGenerator.run`,
:func:`generate_track`) is a loop over :meth:`LiveGenerator.step`, so streaming and offline
generation give identical frames for the same seed.

Jitter (departures, docs/reference/live.md): the pose shown, and passed on to the gaze, is the head
sampler's draws through a causal first-order low-pass of time constant :data:`HEAD_SMOOTH_S`
(the sampler's state stays the draws), and a saccade moves the eyes to their new fixation
offset over :data:`SACCADE_S` (the mean of the last ``round(SACCADE_S * fps)`` offsets). With
the draws shown as they are and saccades in one frame, the head had up to 1.6 times and the
gaze 3.3 times the reference speaker's share of variance above 4 Hz on held-out speech; now
0.5-1.1 and 0.7-0.9 times. Both are times, so any frame rate gets the same motion.

Randomness: one ``numpy`` generator per random process, spawned from ``SeedSequence(seed)``:
the head's variation (or, with ``synthesis="langevin"``, eq. 5's start noise and the Langevin
steps), the blink intervals (eq. 19) and the fixations are drawn in frame order.

Example
-------
>>> gen = LiveGenerator(model, fps=30.0, seed=0)          # doctest: +SKIP
>>> frame = gen.step(f0=180.0, intensity=68.0)            # doctest: +SKIP
>>> dict(zip(OUTPUT_CHANNELS, frame))[48]                 # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from app.stimuli.fap import DEG_PER_AU, EYELIDS, GAZE, HEAD
from app.stimuli.live.audio import AudioFrameStream
from app.stimuli.live.expectation import PoseTracker, frame_expectation
from app.stimuli.live.eyelids import BlinkClock
from app.stimuli.live.gaze import FixationClock
from app.stimuli.live.inputs import LOUDNESS_FLOOR_DB, ContourSmoother, SpeakerNorm, smooth_frames
from app.stimuli.live.model import SYNTHESES, LiveModel
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack

#: FAPs of each output frame, ascending: eyelids 19-22, gaze 23-26, head 48-50.
OUTPUT_CHANNELS: tuple[int, ...] = EYELIDS + GAZE + HEAD
#: Time constant (s) of the causal first-order low-pass on the drawn head pose (a departure).
HEAD_SMOOTH_S = 0.02
#: Duration (s) of a saccade: the fixation offset moves to its new target over this time.
SACCADE_S = 0.1


class LiveGenerator:
    """Stateful per-frame generator. ``fps`` defaults to the model's training frame rate.

    ``synthesis``: ``"expectation"`` (default; needs the model's speech pose) or
    ``"langevin"`` (:data:`app.stimuli.live.model.SYNTHESES`); ``variation`` scales the
    expectation synthesis's variation (1: the training motion's amplitude; 0: the speech-driven
    part alone). ``speaker_norm_s`` overrides the model's per-speaker normalisation time
    constant (0: the training statistics for every speaker).
    """

    def __init__(
        self,
        model: LiveModel,
        *,
        fps: float | None = None,
        seed: int = 0,
        synthesis: str = "expectation",
        variation: float = 1.0,
        speaker_norm_s: float | None = None,
    ) -> None:
        if synthesis not in SYNTHESES:
            raise ValueError(f"synthesis must be one of {SYNTHESES}, got {synthesis!r}")
        if synthesis == "expectation" and model.pose is None:
            raise ValueError("this model has no speech pose: use synthesis='langevin'")
        self.model = model
        self.fps = float(fps or model.fps)
        self.synthesis = synthesis
        head_seq, blink_seq, fix_seq = np.random.SeedSequence(seed).spawn(3)
        self._rng = np.random.default_rng(head_seq)
        self._blinks = BlinkClock(
            model.eyelids.blink, np.random.default_rng(blink_seq), shape=model.eyelids.shape
        )
        self._fixations = FixationClock(
            model.fixations.intervals,
            np.random.default_rng(fix_seq),
            offsets=model.fixations.offsets,
        )
        rest = model.head.kin_mean[:3].copy()
        self._tracker = (
            PoseTracker(model.pose, rest, self.fps, self._rng, variation)
            if synthesis == "expectation" and model.pose is not None
            else None
        )
        norm_s = model.speaker_norm_s if speaker_norm_s is None else speaker_norm_s
        self._norm = SpeakerNorm(model.scale, self.fps, norm_s)
        self._prev1, self._prev2 = rest.copy(), rest.copy()
        self._pose_out = rest.copy()
        self._pose_gain = 1.0 - math.exp(-1.0 / (HEAD_SMOOTH_S * self.fps))
        self._saccade: deque[np.ndarray] = deque(maxlen=max(1, round(SACCADE_S * self.fps)))
        self._noise = model.head.step_std / self.fps
        self._gaze_hat = np.zeros(model.gaze.r)
        self._coupling = model.gaze.coupling()
        self._window = max(1, int(round(model.talk_window_s * self.fps)))
        self._last_loud = -(10**9)
        width = smooth_frames(self.fps)  # 0.125 s (sec. 4), in frames of this stream
        self._smooth_pitch, self._smooth_loud = ContourSmoother(width), ContourSmoother(width)
        self.frame = 0
        self._audio: AudioFrameStream | None = None

    @property
    def blink_log(self) -> list[tuple[float, bool, float]]:
        """(onset time s, talking mode, next interval s) of every blink started so far."""
        return self._blinks.log

    def step(self, f0: float, intensity: float) -> np.ndarray:
        """The next frame, FAP values for :data:`OUTPUT_CHANNELS`, from this frame's F0 (Hz,
        0 or NaN when unvoiced) and intensity (dB; NaN or infinite reads as the floor)."""
        m = self.model
        scale = m.scale
        # Speech input (sec. 4): semitones and floored dB, smoothed over 0.125 s (causal).
        # Not a number or infinite: no reading (the floor, unvoiced).
        loud_db = intensity if math.isfinite(intensity) else LOUDNESS_FLOOR_DB
        loud_db = self._smooth_loud.step(max(loud_db, LOUDNESS_FLOOR_DB))
        # log2(f0) - log2(100), not log2(f0 / 100): a subnormal F0 divided by 100 underflows to 0
        pitch_st = (
            12.0 * (math.log2(f0) - math.log2(100.0)) if math.isfinite(f0) and f0 > 0 else math.nan
        )
        pitch_st = self._smooth_pitch.step(pitch_st)
        pz, lz = self._norm.step(pitch_st, loud_db)
        if self._tracker is not None:
            # Head (sec. 5.1's angle GMMs): their expectation, aligned, plus the variation
            drawn = self._tracker.step(frame_expectation(m.head, pz, lz))
        else:
            # Head (sec. 5.2): eq. 5 start, Langevin steps on eq. 4.
            coeffs = m.head.frame_coefficients(pz, lz)
            start = self._prev1 + self._noise * self._rng.standard_normal(3)
            drawn = m.head.sample(start, self._prev1, self._prev2, self.fps, coeffs, self._rng)
            self._prev2, self._prev1 = self._prev1, drawn
        # the shown pose: the draws low-passed, so their frame-to-frame noise is not jitter
        self._pose_out = self._pose_out + self._pose_gain * (drawn - self._pose_out)
        pose = self._pose_out
        # Mode (sec. 7.1) from loudness: drives the fixations and the blinks.
        if loud_db >= scale.threshold_db:
            self._last_loud = self.frame
        talking = self.frame - self._last_loud < self._window
        time = self.frame / self.fps
        # Gaze (sec. 6): eq. 13-15 on (pose, loudness), plus the fixation offset.
        h = np.array([pose[0], pose[1], pose[2], lz])
        gaze, self._gaze_hat = m.gaze.step(h, self._gaze_hat, self._coupling)
        self._saccade.append(self._fixations.step(time, talking))
        gaze = gaze + sum(self._saccade) / len(self._saccade)  # a saccade spans SACCADE_S
        # Eyelids (sec. 7): blink clock, eq. 18.
        closure = self._blinks.step(time, talking)
        lids = m.eyelids.faps(m.eyelids.openness(gaze), closure)
        self.frame += 1
        out = np.empty(len(OUTPUT_CHANNELS))
        out[:4] = lids
        gaze_au = gaze / DEG_PER_AU
        out[4:8] = (gaze_au[0], gaze_au[0], gaze_au[1], gaze_au[1])
        au = pose / DEG_PER_AU
        out[8:11] = (au[1], au[0], au[2])  # FAP 48 pitch, 49 yaw, 50 roll
        return out

    def push_audio(self, samples: np.ndarray, sample_rate: int) -> np.ndarray:
        """Feed a block of mono audio samples; returns the (k, 11) frames it completed (k >= 0).

        Features come from :class:`app.stimuli.live.audio.AudioFrameStream`, which reads only
        samples up to each frame's time."""
        if self._audio is None:
            self._audio = AudioFrameStream(sample_rate, self.fps)
        elif self._audio.sample_rate != sample_rate:
            raise ValueError(f"sample rate changed from {self._audio.sample_rate} to {sample_rate}")
        feats = self._audio.push(samples)
        out = np.empty((len(feats), len(OUTPUT_CHANNELS)))
        for i, (f0, db) in enumerate(feats):
            out[i] = self.step(f0, db)
        return out

    def run(self, f0: np.ndarray, intensity: np.ndarray) -> np.ndarray:
        """Offline: the frames for whole F0 and intensity arrays, by :meth:`step`."""
        f0 = np.asarray(f0, dtype=np.float64)
        intensity = np.asarray(intensity, dtype=np.float64)
        out = np.empty((len(f0), len(OUTPUT_CHANNELS)))
        for t in range(len(f0)):
            out[t] = self.step(float(f0[t]), float(intensity[t]))
        return out


def generate_track(
    model: LiveModel,
    features: SpeechFeatures,
    *,
    seed: int = 0,
    name: str = "live_gmm",
    **options: Any,
) -> MotionTrack:
    """Offline generation over whole speech features (raw F0, so unvoiced frames stay
    unvoiced): a :class:`MotionTrack` with FAPs 19-26 and 48-50. ``options``: those of
    :class:`LiveGenerator` (``synthesis``, ``variation``, ``speaker_norm_s``)."""
    gen = LiveGenerator(model, fps=features.fps, seed=seed, **options)
    values = gen.run(features.f0, features.intensity)
    return MotionTrack(
        features.fps,
        values,
        OUTPUT_CHANNELS,
        name=name,
        source="live_gmm",
        metadata={
            "condition": "live_gmm",
            "seed": seed,
            "synthesis": gen.synthesis,
            "blinks": len(gen.blink_log),
            "model_training": model.summary,
        },
    )
