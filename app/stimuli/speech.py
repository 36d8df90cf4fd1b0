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
  :data:`MIN_DURATION_S`, longer than ``max_duration`` (default :data:`MAX_DURATION_S`), or
  all digital silence: :class:`~app.errors.InputError`, one line naming the file.

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
from app.stimuli.audiofile import DecodedAudio, read_audio

#: Longest audio accepted by default, in seconds (a study stimulus is a few seconds to minutes).
MAX_DURATION_S = 600.0
#: Shortest audio accepted: Praat's pitch analysis needs a few periods of the pitch floor.
MIN_DURATION_S = 0.1
#: Intensity floor in dB: Praat gives about -300 dB for digital silence; such frames read as this.
INTENSITY_FLOOR_DB = 0.0
#: Peak amplitude (full scale = 1) below which a recording counts as silence.
SILENCE_PEAK = 1e-6


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
    decoded = _check_wav_header(Path(path), max_duration)
    return decoded.samples, decoded.sample_rate


def load_sound(
    path: str | Path, *, max_duration: float = MAX_DURATION_S
) -> tuple[parselmouth.Sound, int]:
    """Read and validate audio as a mono Praat sound; returns it and the original channel count.

    Praat only ever sees checked PCM (``parselmouth.Sound(values, rate)``), never the file:
    its own decoders die on some malformed files (SIGFPE on an MP3 renamed ``.wav``).
    """
    decoded = _check_wav_header(Path(path), max_duration)
    return parselmouth.Sound(decoded.samples, decoded.sample_rate), decoded.channels


def _check_wav_header(path: Path, max_duration: float = MAX_DURATION_S) -> DecodedAudio:
    """Identify, check and decode the file (:func:`app.stimuli.audiofile.read_audio`).

    Container sniffed from the bytes, WAV headers checked against the file's size and the
    limit before anything is allocated, everything else decoded by ffmpeg in a subprocess;
    then the speech checks: at least :data:`MIN_DURATION_S`, not all silence.
    """
    return read_audio(
        path, max_duration=max_duration, min_duration=MIN_DURATION_S, silence_peak=SILENCE_PEAK
    )


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
    (:func:`speaker_pitch_range`). Octave jumps are then removed (:func:`remove_octave_jumps`).
    The intensity window follows Praat's convention of 3.2 periods of the pitch floor.
    ``metadata["audio_file"]`` is the decoder's one line on the file and what was done to it
    (:attr:`app.stimuli.audiofile.DecodedAudio.summary`: container, rate, channels, mixing).
    """
    _check_range(pitch_floor, pitch_ceiling)
    if not np.isfinite(fps) or fps <= 0:
        raise InputError(f"fps must be positive, got {fps!r}", field="fps")
    decoded = _check_wav_header(Path(audio_path), max_duration)
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


#: First-pass F0 range of the two-pass estimate (De Looze & Hirst 2008), Hz.
FIRST_PASS_RANGE = (60.0, 750.0)
#: Second-pass range from the first pass's quartiles: floor = 0.75 x q25, ceiling = 1.5 x q75.
FLOOR_FACTOR, CEILING_FACTOR = 0.75, 1.5
#: The range is widened towards the first pass's extremes at most this factor beyond the
#: quartiles (De Looze & Hirst's ceiling for expressive speech).
WIDEST = 2.5
#: Fewest voiced first-pass frames to trust the quartiles; fewer keeps the first-pass range.
MIN_VOICED_FOR_RANGE = 10
#: A voiced frame further than this (octaves) from the median of its neighbourhood is an error.
OCTAVE_JUMP = 0.6
#: Neighbourhood of that median, seconds (centred; voiced frames only).
OCTAVE_WINDOW_S = 0.3


def _check_range(floor: float | None, ceiling: float | None) -> None:
    for name, value in (("pitch_floor", floor), ("pitch_ceiling", ceiling)):
        if value is not None and not (np.isfinite(value) and value > 0):
            raise InputError(f"{name} must be a positive number of Hz, got {value!r}", field=name)
    if floor is not None and ceiling is not None and not floor < ceiling:
        raise InputError(
            f"need pitch floor < pitch ceiling, got {floor:g} and {ceiling:g}", field="pitch_floor"
        )


def speaker_pitch_range(
    first_pass_f0: np.ndarray,
    floor: float | None = None,
    ceiling: float | None = None,
    fps: float = 30.0,
) -> tuple[float, float, str]:
    """The speaker's F0 floor and ceiling: given values kept where they hold the speaker,
    the rest from the first pass's distribution.

    Two-pass rule of De Looze & Hirst (2008), widely used with Praat: a first pass over
    :data:`FIRST_PASS_RANGE`, its octave jumps removed (:func:`remove_octave_jumps`), then
    ``floor = 0.75 * q25`` and ``ceiling = 1.5 * q75`` of its voiced F0, widened to 0.9 x its
    2nd and 1.1 x its 98th percentile where the speaker reaches further (a glide, wide
    intonation), but never past ``q25 / 2.5`` and ``2.5 * q75`` (:data:`WIDEST`: the first
    pass of a voice at its floor holds a few octave errors its jump removal misses). With
    fewer than :data:`MIN_VOICED_FOR_RANGE` voiced frames the first-pass range stands. A
    given floor above the speaker's first quartile, or a given ceiling below
    the third, does not hold the speaker: a 67 Hz bass analysed over 75-600 Hz read as 500 Hz
    in places, and the estimate replaces it, said in ``how``. Returns ``(floor, ceiling, how)``.

    >>> speaker_pitch_range(np.r_[np.zeros(5), np.linspace(100, 140, 41)])
    (82.5, 195.0, 'two-pass estimate (De Looze & Hirst 2008)')
    >>> speaker_pitch_range(np.full(40, 62.0), 75.0, 600.0)[2]
    'two-pass estimate: the given 75-600 Hz does not hold this speaker (median 62 Hz)'
    """
    voiced = np.asarray(first_pass_f0, dtype=np.float64)
    voiced, _ = remove_octave_jumps(voiced, fps)
    voiced = voiced[voiced > 0]
    estimate = None
    if len(voiced) >= MIN_VOICED_FOR_RANGE:
        q02, q25, q75, q98 = np.percentile(voiced, [2, 25, 75, 98])
        estimate = (  # widened by the extremes, never past 2.5 times the quartiles
            min(FLOOR_FACTOR * q25, max(0.9 * q02, q25 / WIDEST)),
            max(CEILING_FACTOR * q75, min(1.1 * q98, WIDEST * q75)),
        )
    if floor is not None and ceiling is not None:
        holds = estimate is None or (
            floor <= np.percentile(voiced, 25) and ceiling >= np.percentile(voiced, 75)
        )
        if holds:
            return float(floor), float(ceiling), "given"
        assert estimate is not None
        how = (
            f"two-pass estimate: the given {floor:g}-{ceiling:g} Hz does not hold this "
            f"speaker (median {np.median(voiced):.0f} Hz)"
        )
        return round(float(estimate[0]), 3), round(float(estimate[1]), 3), how
    if estimate is None:
        lo, hi = FIRST_PASS_RANGE
        how = "first-pass range (too little voicing to estimate the speaker's)"
    else:
        lo, hi = estimate
        how = "two-pass estimate (De Looze & Hirst 2008)"
    lo = float(floor) if floor is not None else float(lo)
    hi = float(ceiling) if ceiling is not None else float(hi)
    if hi <= lo:  # a given bound beyond the estimate of the other: keep an octave between them
        hi, lo = (2 * lo, lo) if floor is not None else (hi, hi / 2)
    return round(lo, 3), round(hi, 3), how


def remove_octave_jumps(
    f0: np.ndarray, fps: float, max_octaves: float = OCTAVE_JUMP, window_s: float = OCTAVE_WINDOW_S
) -> tuple[np.ndarray, int]:
    """Unvoice frames whose F0 jumps by about an octave from their neighbourhood.

    Autocorrelation pitch trackers halve or double F0 on a few frames (e.g. a 371 Hz frame in
    a 126 Hz male voice), and with a wide pitch range (a fixed 75-600 Hz for a 75 Hz voice) a
    short voiced stretch between pauses can read as a multiple of the voice's F0. A voiced
    frame whose F0 is more than ``max_octaves`` octaves from the median of its neighbourhood is
    set to 0 (unvoiced), so eq. 35's spline bridges it. The neighbourhood is the
    ``2 * round(window_s * fps / 2) + 1`` voiced frames nearest to it in order (shifted
    inwards at the ends of the recording): within ``window_s`` in fluent speech, and reaching
    across the pauses around an isolated stretch, whose own frames would otherwise be their
    only neighbours. A genuine pitch accent rises over 100-200 ms and stays within about half
    an octave of that median. Returns the cleaned F0 and the frames removed.

    >>> remove_octave_jumps(np.array([120, 122, 250, 121, 119, 0, 118.0]), 30.0)[0].tolist()
    [120.0, 122.0, 0.0, 121.0, 119.0, 0.0, 118.0]
    >>> isolated = np.r_[np.full(6, 80.0), np.zeros(6), np.full(3, 360.0), np.zeros(6), 80, 81]
    >>> remove_octave_jumps(isolated, 30.0)[1]
    3
    """
    f0 = np.asarray(f0, dtype=np.float64).copy()
    idx = np.flatnonzero(f0 > 0)
    if len(idx) < 3:
        return f0, 0
    half = max(int(round(window_s * fps / 2)), 1)
    width = min(2 * half + 1, len(idx))
    log_f0 = np.log2(f0[idx])
    starts = np.clip(np.arange(len(idx)) - half, 0, len(idx) - width)
    medians = np.median(log_f0[starts[:, None] + np.arange(width)], axis=1)
    bad = idx[np.abs(log_f0 - medians) > max_octaves]
    f0[bad] = 0.0
    return f0, int(len(bad))


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
