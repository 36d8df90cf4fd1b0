"""The encoder's pieces: exact frame-rate rationals, audio checks, a clean abort."""

import numpy as np
import pytest

from app.errors import InputError
from renderer.encode import ClipWriter, check_audio, fps_arg


@pytest.mark.parametrize(
    "fps, expected",
    [(30.0, "30/1"), (29.97, "2997/100"), (30000 / 1001, "30000/1001"), (25, "25/1")],
)
def test_frame_rates_are_exact_rationals(fps, expected):
    assert fps_arg(fps) == expected


def test_missing_audio_names_the_file(tmp_path):
    with pytest.raises(InputError) as info:
        check_audio(tmp_path / "nope.wav")
    assert "nope.wav" in str(info.value)
    assert check_audio(None) is None


def test_an_error_while_writing_leaves_no_partial_file(tmp_path):
    out = tmp_path / "x.mp4"
    with pytest.raises(RuntimeError, match="boom"):
        with ClipWriter(out, 64, 64, 30.0, 10) as writer:
            writer.write(np.zeros((64, 64, 3), np.uint8))
            raise RuntimeError("boom")
    assert not out.exists()


def test_a_clip_without_audio_has_the_frames_written(tmp_path):

    out = tmp_path / "y.mp4"
    with ClipWriter(out, 64, 48, 25.0, 5) as writer:
        for k in range(5):
            writer.write(np.full((48, 64, 3), 40 * k, np.uint8))
    from tests.renderer.test_api import decode

    meta, decoded = decode(out)
    assert meta["size"] == (64, 48) and len(decoded) == 5
    means = [float(d.mean()) for d in decoded]
    assert means == sorted(means) and abs(means[-1] - 160) < 4


def test_no_tag_of_the_audio_file_reaches_the_clip(tmp_path):
    """Blinding: an audio file whose title and handler name say what a condition is gives a
    clip whose bytes carry neither (ffmpeg copies an input stream's tags by default)."""
    import subprocess

    from renderer.encode import ffmpeg_exe

    audio = tmp_path / "voice.m4a"
    subprocess.run(
        [
            ffmpeg_exe(),
            "-v",
            "error",
            "-f",
            "lavfi",
            "-i",
            "sine=frequency=300:duration=0.4",
            "-metadata",
            "title=zebraface_left",
            "-metadata:s:a:0",
            "handler_name=speech_driven_right",
            "-c:a",
            "aac",
            str(audio),
        ],
        check=True,
    )
    out = tmp_path / "clip.mp4"
    with ClipWriter(out, 64, 48, 25.0, 10, audio) as writer:
        for _ in range(10):
            writer.write(np.zeros((48, 64, 3), np.uint8))
    data = out.read_bytes()
    assert b"zebraface" not in data and b"speech_driven" not in data
