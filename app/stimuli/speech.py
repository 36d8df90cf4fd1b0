"""Speech features per video frame: Praat F0 and intensity, F0 conditioning, smoothed contours.

:class:`SpeechFeatures` is the input every speech-driven condition, the live generator and the
measures read.

Thesis sec. 4.3.4.1: F0 and energy are computed with Praat (Boersma & Weenink); unvoiced frames
are treated as missing and filled by a cubic spline through the voiced frames, and the result is
clipped to [0, max observed F0] (eq. 35). Sec. 4.3.4.2 adds 1-second (30-frame) mean-filtered
contours so the head model works at two time scales.

Audio handling (documented behaviour, see ``docs/reference/stimuli.md``):

- WAV (8/16/24/32-bit PCM, 32/64-bit float) read directly; MP3, FLAC, M4A/AAC, Ogg, WebM,
  AIFF and CAF decoded by ffmpeg in a subprocess (:mod:`app.stimuli.audiofile`). Praat gets
  only the checked samples.
- Several channels are mixed to mono (their mean); ``metadata["mixed_to_mono"]`` records the
  original channel count.
- Not audio, an unsupported encoding or sample width, no samples, shorter than
  :data:`~app.stimuli.speechaudio.MIN_DURATION_S`, longer than ``max_duration`` (default
  :data:`~app.stimuli.speechaudio.MAX_DURATION_S`), or all digital silence
  (:mod:`app.stimuli.speechaudio`): :class:`~app.errors.InputError`, one line naming the file.

Example
-------
>>> import numpy as np
>>> t = np.arange(16000) / 16000
>>> feats = features_from_samples(0.3 * np.sin(2 * np.pi * 150 * t), 16000, fps=30)
>>> feats.n_frames, round(float(np.median(feats.f0[5:-5])))
(30, 150)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import parselmouth
from scipy import interpolate, ndimage

from app.errors import InputError
from app.stimuli.pitchrange import FIRST_PASS_RANGE, remove_octave_jumps, speaker_pitch_range
from app.stimuli.speechaudio import MAX_DURATION_S, read_speech_audio

#: Intensity floor in dB: Praat gives about -300 dB for digital silence; such frames read as this.
INTENSITY_FLOOR_DB = 0.0


@dataclass(eq=False)
class SpeechFeatures:
    """Per-frame speech features at the video frame rate.

    Attributes
    ----------
    fps : frames per second; frame i describes the audio around time i / fps.
    f0 : raw F0 in Hz, 0 where unvoiced (Praat autocorrelation pitch).
    intensity : intensity in dB (Praat, re 2e-5 Pa with samples taken as pascals).
    f0_conditioned : unvoiced gaps filled by a cubic spline through the voiced frames, clipped
        to [0, max observed F0] (thesis sec. 4.3.4.1).
    metadata : audio path, sample rate, duration, channel handling, pitch floor/ceiling.
    """

    fps: float
    f0: np.ndarray
    intensity: np.ndarray
    f0_conditioned: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.f0)
        for name in ("intensity", "f0_conditioned"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"{name} has {len(getattr(self, name))} frames, f0 has {n}")

    @property
    def n_frames(self) -> int:
        return len(self.f0)

    @property
    def voiced(self) -> np.ndarray:
        """Boolean mask of voiced frames (raw F0 > 0)."""
        return np.asarray(self.f0) > 0

    def slice(self, start: int, stop: int) -> SpeechFeatures:
        """Frames ``start:stop`` as new features (for held-out splits and streaming)."""
        return SpeechFeatures(
            self.fps,
            self.f0[start:stop].copy(),
            self.intensity[start:stop].copy(),
            self.f0_conditioned[start:stop].copy(),
            dict(self.metadata),
        )


def load_audio(
    path: str | Path, *, max_duration: float = MAX_DURATION_S
) -> tuple[np.ndarray, float]:
    """Read an audio file as mono float64 samples in [-1, 1] and its sample rate.

    WAV is read directly; MP3, FLAC, M4A/AAC, Ogg and the other containers of
    :mod:`app.stimuli.audiofile` are decoded by ffmpeg in a subprocess. Several channels are
    averaged to mono (use :func:`load_sound` to learn whether that happened). Raises
    :class:`InputError` for anything that is not usable speech audio.
    """
    decoded = read_speech_audio(path, max_duration=max_duration)
    return decoded.samples, decoded.sample_rate


def load_sound(
    path: str | Path, *, max_duration: float = MAX_DURATION_S
) -> tuple[parselmouth.Sound, int]:
    """Read and validate audio as a mono Praat sound; returns it and the original channel count.

    Praat only ever sees checked PCM (``parselmouth.Sound(values, rate)``), never the file:
    its own decoders die on some malformed files (SIGFPE on an MP3 renamed ``.wav``).
    """
    decoded = read_speech_audio(path, max_duration=max_duration)
    return parselmouth.Sound(decoded.samples, decoded.sample_rate), decoded.channels


def extract_features(
    audio_path: str | Path,
    fps: float = 30.0,
    *,
    pitch_floor: float | None = None,
    pitch_ceiling: float | None = None,
    max_duration: float = MAX_DURATION_S,
) -> SpeechFeatures:
    """F0 (Hz, 0 unvoiced), intensity (dB) and conditioned F0 per video frame of an audio file.

    Praat's autocorrelation pitch and intensity run with time step = the frame period ``1/fps``
    and are read at the frame times ``i / fps`` for ``i < round(duration * fps)`` (thesis sec.
    4.3.4.1). ``pitch_floor``/``pitch_ceiling`` are the speaker's F0 range (e.g. 75-300 Hz for
    a male voice); one left ``None`` is estimated from the recording in two passes
    (:func:`app.stimuli.pitchrange.speaker_pitch_range`). Octave jumps are then removed
    (:func:`app.stimuli.pitchrange.remove_octave_jumps`).
    The intensity window follows Praat's convention of 3.2 periods of the pitch floor.
    ``metadata["audio_file"]`` is the decoder's one line on the file and what was done to it
    (:attr:`app.stimuli.audiofile.DecodedAudio.summary`: container, rate, channels, mixing).
    """
    _check_range(pitch_floor, pitch_ceiling)
    if not np.isfinite(fps) or fps <= 0:
        raise InputError(f"fps must be positive, got {fps!r}", field="fps")
    decoded = read_speech_audio(audio_path, max_duration=max_duration)
    sound = parselmouth.Sound(decoded.samples, decoded.sample_rate)
    feats = _features(sound, fps, pitch_floor, pitch_ceiling)
    feats.metadata.update(
        audio=str(audio_path),
        channels=decoded.channels,
        mixed_to_mono=decoded.channels > 1,
        audio_file=decoded.summary,
    )
    return feats


def features_from_samples(
    samples: np.ndarray,
    sample_rate: float,
    fps: float = 30.0,
    *,
    pitch_floor: float | None = None,
    pitch_ceiling: float | None = None,
) -> SpeechFeatures:
    """Like :func:`extract_features`, from mono samples already in memory (tests, streams)."""
    _check_range(pitch_floor, pitch_ceiling)
    sound = parselmouth.Sound(np.asarray(samples, dtype=np.float64), float(sample_rate))
    return _features(sound, fps, pitch_floor, pitch_ceiling)


def _check_range(floor: float | None, ceiling: float | None) -> None:
    for name, value in (("pitch_floor", floor), ("pitch_ceiling", ceiling)):
        if value is not None and not (np.isfinite(value) and value > 0):
            raise InputError(f"{name} must be a positive number of Hz, got {value!r}", field=name)
    if floor is not None and ceiling is not None and not floor < ceiling:
        raise InputError(
            f"need pitch floor < pitch ceiling, got {floor:g} and {ceiling:g}", field="pitch_floor"
        )


def _pitch(
    sound: parselmouth.Sound, fps: float, floor: float, ceiling: float, t: np.ndarray
) -> np.ndarray:
    pitch = sound.to_pitch_ac(time_step=1.0 / fps, pitch_floor=floor, pitch_ceiling=ceiling)
    return _read_f0(pitch.xs(), pitch.selected_array["frequency"], t)


def _features(
    sound: parselmouth.Sound, fps: float, floor: float | None, ceiling: float | None
) -> SpeechFeatures:
    n = round(sound.duration * fps)
    t = np.arange(n) / fps
    # the first pass runs even with a given range: it tells whether that range holds the
    # speaker (speaker_pitch_range)
    first = _pitch(sound, fps, *FIRST_PASS_RANGE, t)
    floor, ceiling, how = speaker_pitch_range(first, floor, ceiling, fps)
    f0, n_jumps = remove_octave_jumps(_pitch(sound, fps, floor, ceiling, t), fps)
    inten = sound.to_intensity(minimum_pitch=floor, time_step=1.0 / fps)
    db = np.maximum(inten.values[0], INTENSITY_FLOOR_DB)
    if len(db) >= 2:
        intensity = np.interp(t, inten.xs(), db)
    else:  # shorter than one intensity window: one value for the whole sound
        intensity = np.full(n, float(db[0]) if len(db) else INTENSITY_FLOOR_DB)
    meta = dict(
        sample_rate=float(sound.sampling_frequency),
        duration=float(sound.duration),
        pitch_floor=floor,
        pitch_ceiling=ceiling,
        pitch_range=how,
        octave_jumps_removed=n_jumps,
    )
    return SpeechFeatures(float(fps), f0, intensity, condition_f0(f0), meta)


def _read_f0(xs: np.ndarray, freq: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Praat pitch frames read at times ``t``: linear between two voiced frames, else nearest."""
    if len(xs) == 0:
        return np.zeros(len(t))
    if len(xs) == 1:
        return np.full(len(t), float(freq[0]))
    dt = xs[1] - xs[0]
    pos = np.clip((t - xs[0]) / dt, 0, len(xs) - 1)
    i0 = np.minimum(np.floor(pos).astype(int), len(xs) - 2)
    w = pos - i0
    a, b = freq[i0], freq[i0 + 1]
    nearest = np.where(w < 0.5, a, b)
    return np.where((a > 0) & (b > 0), a + w * (b - a), nearest)


def condition_f0(f0: np.ndarray) -> np.ndarray:
    """Thesis eq. 35: unvoiced gaps filled by a cubic spline through the voiced frames, clipped.

    ``F0cond = min(max(spline(F0), 0), max(F0))``. Before the first and after the last voiced
    frame the spline is not extrapolated (a cubic runs away over a long pause): the edge voiced
    value is held. No voiced frame at all gives zeros.

    >>> condition_f0(np.array([0, 100.0, 0, 120.0, 0])).tolist()
    [100.0, 100.0, 110.0, 120.0, 120.0]
    """
    f0 = np.asarray(f0, dtype=np.float64)
    voiced = np.flatnonzero(f0 > 0)
    if len(voiced) == 0:
        return np.zeros_like(f0)
    if len(voiced) == 1:
        return np.full_like(f0, f0[voiced[0]])
    frames = np.arange(len(f0))
    inner = np.clip(frames, voiced[0], voiced[-1])
    spline = interpolate.CubicSpline(voiced, f0[voiced])
    out = spline(inner)
    return np.clip(out, 0.0, f0[voiced].max())


def mean_filter(x: np.ndarray, width: int, *, causal: bool = False) -> np.ndarray:
    """Moving average over ``width`` frames (edges repeat the end value).

    Centred by default (offline generation); ``causal=True`` averages the current and the
    ``width - 1`` previous frames, for streaming use.
    """
    x = np.asarray(x, dtype=np.float64)
    width = max(int(width), 1)
    if width == 1 or len(x) == 0:
        return x.copy()
    origin = (width - 1) // 2 if causal else 0
    if causal and width % 2 == 0:
        origin = width // 2 - 1
    return ndimage.uniform_filter1d(x, width, mode="nearest", origin=origin)


def smooth_3(x: np.ndarray) -> np.ndarray:
    """3-frame mean filter (the short time scale)."""
    return mean_filter(x, 3)


def smooth_1s(x: np.ndarray, fps: float, *, causal: bool = False) -> np.ndarray:
    """1-second mean filter, ``round(fps)`` frames (thesis sec. 4.3.4.2: 30 frames at 30 fps)."""
    return mean_filter(x, round(fps), causal=causal)


def loudness_sones(intensity_db: np.ndarray) -> np.ndarray:
    """Loudness in sones from intensity in dB, Stevens' rule ``2 ** ((L - 40) / 10)``.

    Intensity stands in for loudness level (phon), which ignores the ear's frequency weighting;
    good enough to compare frames of one recording.

    >>> loudness_sones(np.array([40.0, 50.0])).tolist()
    [1.0, 2.0]
    """
    return np.power(2.0, (np.asarray(intensity_db, dtype=np.float64) - 40.0) / 10.0)
