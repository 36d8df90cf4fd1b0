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
