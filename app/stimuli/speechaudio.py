"""Speech recordings: the limits a file must meet before the speech pipeline analyses it.

:func:`app.stimuli.audiofile.read_audio` decodes any audio file to checked mono samples; a
recording of speech must also be long enough for Praat's pitch analysis
(:data:`MIN_DURATION_S`), no longer than a stimulus may be (:data:`MAX_DURATION_S`) and not all
digital silence (:data:`SILENCE_PEAK`), or there is nothing to read F0 and intensity from
(thesis sec. 4.3.4.1). :func:`read_speech_audio` reads a file under these limits, as
:mod:`app.stimuli.speech` does before Praat sees the samples, and :func:`check_audio_file`
gives an upload form the same verdict without loading Praat (documented behaviour, see
``docs/reference/stimuli.md``).
"""

from __future__ import annotations

from pathlib import Path

from app.stimuli.audiofile import DecodedAudio, read_audio

#: Longest audio accepted by default, in seconds (a study stimulus is a few seconds to minutes).
MAX_DURATION_S = 600.0
#: Shortest audio accepted: Praat's pitch analysis needs a few periods of the pitch floor.
MIN_DURATION_S = 0.1
#: Peak amplitude (full scale = 1) below which a recording counts as silence.
SILENCE_PEAK = 1e-6


def check_audio_file(path: str | Path, *, max_duration: float | None = None) -> str:
    """Check an uploaded audio file as the speech pipeline will read it; its summary line.

    The same checks as :func:`app.stimuli.speech.load_sound` (container, header, length,
    silence), so a form can refuse a bad file with the line of :class:`InputError` it raises
    before a job ever meets the file.

    >>> check_audio_file("app/data/demo/speech.wav")  # doctest: +SKIP
    'speech.wav: WAV (16-bit PCM), 16000 Hz, mono, 4.00 s; read directly'
    """
    return read_speech_audio(path, max_duration=max_duration).summary


def read_speech_audio(path: str | Path, *, max_duration: float | None = None) -> DecodedAudio:
    """:func:`app.stimuli.audiofile.read_audio` with the speech pipeline's limits (length,
    silence)."""
    return read_audio(
        path,
        max_duration=MAX_DURATION_S if max_duration is None else max_duration,
        min_duration=MIN_DURATION_S,
        silence_peak=SILENCE_PEAK,
    )
