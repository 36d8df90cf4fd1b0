"""Headphone screening sounds: the audio check a participant takes before the first trial.

The study's question is about coherence with speech, so a participant must hear it. Two
three-interval tests are generated here (numpy only), each telling headphones from
loudspeakers:

- **Huggins pitch** (Milne, Bianco, Poole, Zhao, Oxenham, Billig & Chait 2021, "An online
  headphone screening test based on dichotic pitch", Behavior Research Methods 53): white
  noise in both ears, identical except for a narrow band around 600 Hz whose phase is
  inverted in one ear. Over headphones the band is heard as a faint tone inside the noise;
  over loudspeakers the ears' signals mix in the air and no tone is heard. Two intervals are
  plain diotic noise, one carries the Huggins pitch: "which sound has the tone?".
- **Antiphase** (Woods, Siegel, Traer & McDermott 2017, "Headphone screening to facilitate
  web-based auditory experiments", Attention, Perception, & Psychophysics 79): three 200 Hz
  tones, one 6 dB quieter, one in antiphase between the ears (one channel's polarity
  inverted) at the full level. Over loudspeakers the antiphase tone cancels in the air and
  sounds quietest; over headphones the truly quieter tone does: "which sound is the
  quietest?" (its answer is the -6 dB tone).

Both papers use six trials and pass a participant with at least five right
(:class:`app.trials.participation.AudioCheckSpec`). Each interval is one second long with
raised-cosine ramps, separated by half a second of silence.

>>> import numpy as np
>>> sound = three_intervals("huggins", target=2, rng=np.random.default_rng(0))
>>> sound.shape, sound.dtype
((88200, 2), dtype('float64'))
"""

from __future__ import annotations

import io
import wave
from typing import Final

import numpy as np
from numpy.typing import NDArray

RATE: Final = 22050
"""Sample rate of the check's WAV files (Hz): ample for a 600 Hz band and a 200 Hz tone."""
INTERVAL_S: Final = 1.0
GAP_S: Final = 0.5
RAMP_S: Final = 0.02
HUGGINS_CENTRE_HZ: Final = 600.0
HUGGINS_BANDWIDTH: Final = 0.06
"""The inverted band's width as a fraction of its centre (582 to 618 Hz around 600 Hz)."""
ANTIPHASE_HZ: Final = 200.0
QUIETER_DB: Final = -6.0
LEVEL_RMS: Final = 0.1
"""RMS of every interval (about -20 dBFS): loud enough to hear, far from clipping."""
KINDS: Final = ("huggins", "antiphase")


def _ramped(samples: NDArray[np.float64], rate: int) -> NDArray[np.float64]:
    """Raised-cosine onset and offset ramps, so no interval starts or stops with a click."""
    n = min(int(RAMP_S * rate), len(samples) // 2)
    envelope = np.ones(len(samples))
    ramp = 0.5 - 0.5 * np.cos(np.pi * np.arange(n) / n)
    envelope[:n], envelope[len(samples) - n :] = ramp, ramp[::-1]
    return samples * envelope[:, None] if samples.ndim == 2 else samples * envelope


def huggins_interval(
    rng: np.random.Generator,
    *,
    pitch: bool,
    rate: int = RATE,
    seconds: float = INTERVAL_S,
    centre: float = HUGGINS_CENTRE_HZ,
    bandwidth: float = HUGGINS_BANDWIDTH,
) -> NDArray[np.float64]:
    """One noise interval, ``(n, 2)`` (left, right): diotic white noise, with ``pitch`` the
    band ``centre * (1 +- bandwidth / 2)`` phase-inverted (multiplied by -1 in the spectrum)
    in the right ear only (Milne et al. 2021).

    >>> x = huggins_interval(np.random.default_rng(1), pitch=False)
    >>> bool(np.array_equal(x[:, 0], x[:, 1]))
    True
    """
    n = int(seconds * rate)
    spectrum = np.fft.rfft(rng.standard_normal(n))
    right = spectrum.copy()
    if pitch:
        frequencies = np.fft.rfftfreq(n, 1.0 / rate)
        band = np.abs(frequencies - centre) <= centre * bandwidth / 2
        right[band] *= -1.0
    stereo = np.stack([np.fft.irfft(spectrum, n), np.fft.irfft(right, n)], axis=1)
    return stereo * (LEVEL_RMS / np.sqrt(np.mean(stereo**2)))


def antiphase_interval(
    *, quieter: bool = False, antiphase: bool = False, rate: int = RATE, seconds: float = INTERVAL_S
) -> NDArray[np.float64]:
    """One 200 Hz tone, ``(n, 2)``: at the full level, 6 dB below it (``quieter``), or at the
    full level with the right channel's polarity inverted (``antiphase``; Woods et al. 2017).

    >>> x = antiphase_interval(antiphase=True)
    >>> bool(np.allclose(x[:, 0], -x[:, 1]))
    True
    """
    t = np.arange(int(seconds * rate)) / rate
    tone = np.sqrt(2.0) * LEVEL_RMS * np.sin(2 * np.pi * ANTIPHASE_HZ * t)
    if quieter:
        tone = tone * 10 ** (QUIETER_DB / 20)
    return np.stack([tone, -tone if antiphase else tone], axis=1)


def three_intervals(
    kind: str, *, target: int, rng: np.random.Generator, rate: int = RATE
) -> NDArray[np.float64]:
    """The three intervals of one trial, ramped and separated by silence, ``(n, 2)`` floats in
    [-1, 1]; ``target`` (0, 1 or 2) is the interval to be chosen: the Huggins pitch, or the
    truly quieter antiphase-test tone (the antiphase one takes another place, drawn from
    ``rng``)."""
    if kind not in KINDS:
        raise ValueError(f"kind: expected one of {', '.join(KINDS)}, got {kind!r}")
    if target not in (0, 1, 2):
        raise ValueError(f"target: expected 0, 1 or 2, got {target!r}")
    if kind == "huggins":
        intervals = [huggins_interval(rng, pitch=i == target, rate=rate) for i in range(3)]
    else:
        others = [i for i in range(3) if i != target]
        inverted = others[int(rng.integers(2))]
        intervals = [
            antiphase_interval(quieter=i == target, antiphase=i == inverted, rate=rate)
            for i in range(3)
        ]
    gap = np.zeros((int(GAP_S * rate), 2))
    parts: list[NDArray[np.float64]] = []
    for index, interval in enumerate(intervals):
        parts += [gap] if index else []
        parts.append(_ramped(interval, rate))
    return np.clip(np.concatenate(parts), -1.0, 1.0)


def interval_onsets(rate: int = RATE) -> list[float]:
    """When each interval starts, in seconds (the page marks the sound playing).

    >>> interval_onsets()
    [0.0, 1.5, 3.0]
    """
    step = int(INTERVAL_S * rate) + int(GAP_S * rate)
    return [round(i * step / rate, 3) for i in range(3)]


def targets(seed: int, trials: int) -> list[int]:
    """The position (0, 1 or 2) of the interval to be chosen in each trial, drawn from
    ``seed``: each position as often as ``trials`` allows, in a random order.

    >>> sorted(targets(7, 6))
    [0, 0, 1, 1, 2, 2]
    """
    rng = np.random.default_rng(seed)
    positions = [i % 3 for i in range(trials)]
    rng.shuffle(positions)
    return [int(p) for p in positions]


def wav_bytes(samples: NDArray[np.float64], rate: int = RATE) -> bytes:
    """``samples`` (``(n, channels)`` floats in [-1, 1]) as a 16-bit PCM WAV file."""
    pcm = np.round(np.clip(samples, -1.0, 1.0) * 32767).astype("<i2")
    out = io.BytesIO()
    with wave.open(out, "wb") as wav:
        wav.setnchannels(pcm.shape[1] if pcm.ndim == 2 else 1)
        wav.setsampwidth(2)
        wav.setframerate(rate)
        wav.writeframes(pcm.tobytes())
    return out.getvalue()
