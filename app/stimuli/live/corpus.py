"""Speech for training and testing the live model: resynthesised voices of one recording.

The held-out evaluation of the live generator (:mod:`app.stimuli.live.evaluation`) needs
several takes of speech that differ from each other the way different utterances and speakers
do, with pauses between them (the paper's talking and listening modes, Le, Ma & Deng 2012 sec.
7.1). From one recording, Praat's "Change gender" (PSOLA resynthesis) makes *voices*: the same
words with another pitch median, pitch range and speaking rate. A *take* is a sequence of
utterances, each in a voice drawn from a given set, separated by pauses of quiet noise.

Two disjoint voice sets, :data:`TRAIN_VOICES` and :data:`TEST_VOICES`, keep the splits
explicit: a model trained on takes in the training voices is tested on takes in voices it never
heard (other pitch medians, ranges and rates), with motion of another reference-speaker seed.

Example
-------
>>> from app.stimuli.speech import load_sound
>>> sound, _ = load_sound("app/data/demo/speech.wav")              # doctest: +SKIP
>>> feats = speech_take(sound, TEST_VOICES, 60.0, seed=1)      # doctest: +SKIP
>>> feats.n_frames                                             # doctest: +SKIP
1800
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import parselmouth
from parselmouth.praat import call

from app.stimuli.speech import SpeechFeatures, features_from_samples


class Voice(NamedTuple):
    """A resynthesised voice: pitch median (Hz), pitch range factor and duration factor."""

    pitch_median_hz: float
    pitch_range: float
    duration: float


#: Voices of the training takes.
TRAIN_VOICES: tuple[Voice, ...] = (
    Voice(95.0, 1.0, 1.0),
    Voice(125.0, 1.4, 0.9),
    Voice(160.0, 0.8, 1.15),
    Voice(110.0, 1.2, 1.25),
)
#: Voices of the test takes: none of them is a training voice.
TEST_VOICES: tuple[Voice, ...] = (
    Voice(105.0, 1.3, 0.85),
    Voice(140.0, 0.9, 1.05),
    Voice(180.0, 1.1, 1.2),
)
#: Pauses between utterances, seconds (uniform).
PAUSE_S = (0.4, 3.0)
#: Level of the noise in pauses, relative to full scale (about -66 dBFS rms).
PAUSE_NOISE = 5e-4


def resynthesise(
    sound: parselmouth.Sound,
    voice: Voice,
    *,
    pitch_floor: float = 75.0,
    pitch_ceiling: float = 300.0,
) -> parselmouth.Sound:
    """``sound`` spoken in ``voice`` (Praat "Change gender", formants kept)."""
    return call(
        sound,
        "Change gender",
        pitch_floor,
        pitch_ceiling,
        1.0,
        voice.pitch_median_hz,
        voice.pitch_range,
        voice.duration,
    )


def speech_take(
    sound: parselmouth.Sound,
    voices: Sequence[Voice],
    seconds: float,
    *,
    seed: int,
    fps: float = 30.0,
    pitch_floor: float = 75.0,
    pitch_ceiling: float = 400.0,
) -> SpeechFeatures:
    """Speech features of a take of about ``seconds``: utterances of ``sound`` in voices drawn
    (seeded) from ``voices``, each followed by a pause of :data:`PAUSE_S`. The same seed gives
    the same take in any process (Praat's random generator is seeded for the resynthesis).

    ``pitch_floor``/``pitch_ceiling`` are the analysis range of the take's features (the
    voices reach about 250 Hz); the resynthesis reads the source with 75-300 Hz.
    """
    if not voices:
        raise ValueError("no voices to draw from")
    rng = np.random.default_rng(seed)
    rate = float(sound.sampling_frequency)
    # Praat's overlap-add fills unvoiced stretches from its own random generator: seeded here,
    # or every process would make another take from the same seed
    parselmouth.praat.run(f"random_initializeWithSeedUnsafelyButPredictably ({int(seed)})")
    try:
        rendered = [resynthesise(sound, v).values[0] for v in voices]
    finally:
        parselmouth.praat.run("random_initializeSafelyAndUnpredictably ()")
    pieces: list[np.ndarray] = []
    total = 0
    while total < seconds * rate:
        utterance = rendered[int(rng.integers(len(rendered)))]
        pause = rng.normal(0.0, PAUSE_NOISE, round(rng.uniform(*PAUSE_S) * rate))
        pieces += [utterance, pause]
        total += len(utterance) + len(pause)
    samples = np.concatenate(pieces)[: round(seconds * rate)]
    feats = features_from_samples(
        samples, rate, fps, pitch_floor=pitch_floor, pitch_ceiling=pitch_ceiling
    )
    feats.metadata.update(take_seed=seed, voices=[list(v) for v in voices])
    return feats
