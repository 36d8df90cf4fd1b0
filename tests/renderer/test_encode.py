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
    from tests.support.clips import decode

    meta, decoded = decode(out)
    assert meta["size"] == (64, 48) and len(decoded) == 5
    means = [float(d.mean()) for d in decoded]
    assert means == sorted(means) and abs(means[-1] - 160) < 4


def test_no_tag_of_the_audio_file_reaches_the_clip(tmp_path):
    """Blinding: an audio file whose title and handler name say what a condition is gives a
    clip whose bytes carry neither (ffmpeg copies an input stream's tags by default)."""
    audio = _tagged_audio(tmp_path)
    out = tmp_path / "clip.mp4"
    with ClipWriter(out, 64, 48, 25.0, 10, audio) as writer:
        for _ in range(10):
            writer.write(np.zeros((48, 64, 3), np.uint8))
    data = out.read_bytes()
    assert b"zebraface" not in data and b"speech_driven" not in data


def _tagged_audio(tmp_path):
    """An audio file whose title and handler name say what a condition is."""
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
    return audio


def _listing(path) -> str:
    """What ffmpeg reads of a file's container and streams (``ffmpeg -i``, as ffprobe does)."""
    import subprocess

    from renderer.encode import ffmpeg_exe

    return subprocess.run(
        [ffmpeg_exe(), "-hide_banner", "-nostdin", "-i", str(path)], capture_output=True, text=True
    ).stderr


def _tags(listing: str) -> dict[str, set[str]]:
    """Every metadata key ffmpeg lists, with its values."""
    import re

    tags: dict[str, set[str]] = {}
    for key, value in re.findall(r"^\s{4,}(\w+)\s*: (.*)$", listing, flags=re.M):
        tags.setdefault(key.lower(), set()).add(value.strip())
    return tags


def _assert_blinded_webm(path, frames: int) -> None:
    """A WebM of VP9 and Opus whose container says nothing but the muxer's bare name and the
    streams' durations: no title, no encoder version, nothing of the audio file's tags."""
    listing = _listing(path)
    assert "Input #0, matroska,webm" in listing
    assert "Video: vp9" in listing and "Audio: opus" in listing
    tags = _tags(listing)
    assert set(tags) == {"encoder", "duration"}, tags
    assert tags["encoder"] == {"Lavf"}  # Matroska's mandatory muxing app, without a version
    data = path.read_bytes()
    for leak in (b"zebraface", b"speech_driven", b"Lavc", b"libvpx", b"title"):
        assert leak not in data, leak
    from tests.support.clips import decode

    meta, decoded = decode(path)
    assert meta["size"] == (64, 48) and len(decoded) == frames


def test_the_webm_rendition_is_written_from_the_same_frames_and_blinded(tmp_path):
    out, webm = tmp_path / "clip.mp4", tmp_path / "clip.webm"
    with ClipWriter(out, 64, 48, 25.0, 10, _tagged_audio(tmp_path), webm_path=webm) as writer:
        for k in range(10):
            writer.write(np.full((48, 64, 3), 20 * k, np.uint8))
    _assert_blinded_webm(webm, 10)
    # the same length as the MP4: the audio padded and cut to the frames in both (Opus to
    # its next 20 ms packet)
    assert "Duration: 00:00:00.40" in _listing(out)
    assert _tags(_listing(webm))["duration"] == {"00:00:00.400000000", "00:00:00.408000000"}


def test_a_finished_mp4_gets_its_webm_rendition(tmp_path):
    from renderer.encode import write_webm

    out = tmp_path / "clip.mp4"
    with ClipWriter(out, 64, 48, 25.0, 10, _tagged_audio(tmp_path)) as writer:
        for k in range(10):
            writer.write(np.full((48, 64, 3), 20 * k, np.uint8))
    assert write_webm(out, tmp_path / "old.webm") == tmp_path / "old.webm"
    _assert_blinded_webm(tmp_path / "old.webm", 10)
    assert not list(tmp_path.glob("*.part.*"))
    with pytest.raises(InputError, match="nope.mp4"):
        write_webm(tmp_path / "nope.mp4", tmp_path / "nope.webm")


def test_an_aborted_clip_leaves_neither_rendition(tmp_path):
    out, webm = tmp_path / "x.mp4", tmp_path / "x.webm"
    with pytest.raises(RuntimeError, match="boom"):
        with ClipWriter(out, 64, 64, 30.0, 10, webm_path=webm) as writer:
            writer.write(np.zeros((64, 64, 3), np.uint8))
            raise RuntimeError("boom")
    assert not out.exists() and not webm.exists()
