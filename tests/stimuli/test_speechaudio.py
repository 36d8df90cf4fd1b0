"""Speech recordings: a file is refused where the speech pipeline would refuse it."""

from pathlib import Path

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.speechaudio import MIN_DURATION_S, check_audio_file, read_speech_audio
from tests.stimuli.conftest import write_wav

ROOT = Path(__file__).resolve().parents[2]


def test_check_audio_file_refuses_what_the_pipeline_would(tmp_path):
    write_wav(tmp_path / "quiet.wav", np.zeros(16000))
    with pytest.raises(InputError, match="all silence"):
        check_audio_file(tmp_path / "quiet.wav")
    assert check_audio_file(ROOT / "app/data/demo/speech.wav").startswith(
        "speech.wav: WAV (16-bit PCM), 16000 Hz, mono"
    )


def test_a_recording_is_held_to_the_speech_limits(tmp_path):
    tone = 0.3 * np.sin(2 * np.pi * 150 * np.arange(16000) / 16000)
    write_wav(tmp_path / "short.wav", tone[: int(16000 * MIN_DURATION_S / 2)])
    with pytest.raises(InputError, match="ms is needed for pitch analysis"):
        read_speech_audio(tmp_path / "short.wav")
    write_wav(tmp_path / "second.wav", tone)
    assert read_speech_audio(tmp_path / "second.wav").duration == 1.0
    with pytest.raises(InputError, match="the limit is 0.5 s"):
        read_speech_audio(tmp_path / "second.wav", max_duration=0.5)
