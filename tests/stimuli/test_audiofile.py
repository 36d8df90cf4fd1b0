"""Audio as people have it: sniffed containers, checked WAV headers, ffmpeg in a subprocess."""

import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli import audiofile
from app.stimuli.audiofile import read_audio, sniff_container
from app.stimuli.speech import features_from_samples, load_audio, load_sound
from app.stimuli.speechaudio import check_audio_file
from tests.stimuli.conftest import harmonic_glide, write_wav

ROOT = Path(__file__).resolve().parents[2]
FFMPEG = imageio_ffmpeg.get_ffmpeg_exe()


def _wav_bytes(
    data: bytes,
    *,
    tag: int = 1,
    channels: int = 1,
    rate: int = 16000,
    width: int = 2,
    bits: int | None = None,
    declared: int | None = None,
    riff: bytes = b"RIFF",
) -> bytes:
    e = "<" if riff == b"RIFF" else ">"
    align = channels * width
    fmt = struct.pack(e + "HHIIHH", tag, channels, rate, rate * align, align, bits or 8 * width)
    size = len(data) if declared is None else declared
    body = b"WAVE" + b"fmt " + struct.pack(e + "I", 16) + fmt + b"data"
    return (
        riff
        + struct.pack(e + "I", 4 + len(body) + len(data))
        + body
        + struct.pack(e + "I", size)
        + data
    )


def _encode(src: Path, dst: Path, *args: str) -> Path:
    subprocess.run(
        [FFMPEG, "-v", "error", "-nostdin", "-y", "-i", str(src), *args, str(dst)], check=True
    )
    return dst


def _one_line_naming(err: pytest.ExceptionInfo, path: Path) -> str:
    message = str(err.value)
    assert "\n" not in message and message.startswith(str(path))
    return message


def _id3_then_noise(path: Path) -> Path:
    """An ID3v2 tag and noise: an MP3 with its audio frames gone, renamed ``.wav`` (5 KB)."""
    tag = b"ID3\x03\x00\x00\x00\x00\x00\x10" + b"\x00" * 16
    path.write_bytes(tag + np.random.default_rng(0).bytes(5000))
    return path


def test_mp3_renamed_wav_with_broken_frames_is_one_line_not_a_signal(tmp_path):
    # Praat's own reader dies on this file with SIGFPE (exit 136), so load it in a child
    # process: the test itself must survive the code it tests.
    bad = _id3_then_noise(tmp_path / "speech.wav")
    code = (
        "import sys\nfrom app.errors import InputError\nfrom app.stimuli.speech import load_sound\n"
        f"try:\n    load_sound({str(bad)!r})\nexcept InputError as e:\n"
        "    print(e)\n    sys.exit(2)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2, (done.returncode, done.stderr[-300:])
    line = done.stdout.strip()
    assert "\n" not in line and line.startswith(str(bad)) and "MP3" in line


def test_real_mp3_renamed_wav_is_decoded_and_said_so(tmp_path):
    x, _ = harmonic_glide(150, 150, 1.0)
    write_wav(tmp_path / "a.wav", x)
    mp3 = _encode(tmp_path / "a.wav", tmp_path / "a.mp3", "-c:a", "libmp3lame")
    renamed = tmp_path / "take.wav"
    renamed.write_bytes(mp3.read_bytes())
    summary = check_audio_file(renamed)
    assert summary.startswith("take.wav: MP3 content in a .wav file (mp3), 16000 Hz, mono")
    assert "decoded by ffmpeg" in summary


def test_header_claiming_256m_samples_is_refused_before_allocating(tmp_path):
    bad = tmp_path / "claims.wav"
    bad.write_bytes(_wav_bytes(b"\x01\x02" * 1000, declared=2 * 256 * 2**20))
    assert bad.stat().st_size < 2100
    with pytest.raises(InputError) as err:
        load_audio(bad)
    message = _one_line_naming(err, bad)
    assert "truncated" in message and "268435456 samples" in message
    # Peak memory of a fresh process reading it: it used to reach 2.2 GB before the limit.
    # VmHWM is the new process's own (ru_maxrss starts from the forking parent's on Linux).
    code = (
        "from app.stimuli.speech import load_sound\n"
        f"try:\n    load_sound({str(bad)!r})\nexcept ValueError:\n    pass\n"
        "status = open('/proc/self/status').read().split('VmHWM:')[1]\n"
        "print(status.split()[0])"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-300:]
    assert int(done.stdout.split()[-1]) < 400 * 1024  # kB: the interpreter and its imports


def test_claimed_length_beyond_the_limit_is_refused_from_the_header(tmp_path):
    path = tmp_path / "long.wav"
    x, _ = harmonic_glide(150, 150, 2.0)
    write_wav(path, x)
    with pytest.raises(InputError, match="2.0 s long; the limit is 1 s"):
        read_audio(path, max_duration=1.0)


def test_wav_cut_in_half_is_refused_with_what_is_missing(tmp_path):
    path = tmp_path / "half.wav"
    x, _ = harmonic_glide(150, 150, 2.0)
    write_wav(path, x)
    raw = path.read_bytes()
    path.write_bytes(raw[: 44 + (len(raw) - 44) // 2])
    with pytest.raises(InputError) as err:
        load_audio(path)
    message = _one_line_naming(err, path)
    assert "declares 32000 samples (2.000 s), the file holds 16000 (1.000 s)" in message
    assert "1.000 s (50 %) is missing" in message


def test_streamed_wav_without_a_length_is_read_to_its_end(tmp_path):
    data = (np.arange(4000) % 200 - 100).astype("<i2").tobytes()
    path = tmp_path / "stream.wav"
    path.write_bytes(_wav_bytes(data, declared=0xFFFFFFFF))
    samples, rate = load_audio(path)
    assert rate == 16000 and len(samples) == 4000
    np.testing.assert_array_equal(samples, (np.arange(4000) % 200 - 100) / 32768)


@pytest.mark.parametrize(
    "width,tag,riff,dtype",
    [(1, 1, b"RIFF", None), (3, 1, b"RIFF", None), (4, 3, b"RIFF", "<f4"), (2, 1, b"RIFX", ">i2")],
)
def test_sample_codings_decode_to_known_values(tmp_path, width, tag, riff, dtype):
    want = np.array([0.0, 0.5, -0.5, 0.25, -1.0])
    if width == 1:
        data = (want * 128 + 128).astype(np.uint8).tobytes()
    elif width == 3:
        ints = (want * 2**23).astype("<i4")
        data = b"".join(int(v).to_bytes(4, "little", signed=True)[:3] for v in ints)
    elif tag == 3:
        data = want.astype(dtype).tobytes()
    else:
        data = (want * 32768).astype(dtype).tobytes()
    path = tmp_path / "codes.wav"
    path.write_bytes(_wav_bytes(data * 400, tag=tag, width=width, riff=riff))
    samples, _ = load_audio(path)
    np.testing.assert_array_equal(samples[:5], want)


def _stereo_source(tmp_path: Path) -> tuple[Path, np.ndarray]:
    x, _ = harmonic_glide(150, 150, 1.0, sr=16000)
    path = tmp_path / "src.wav"
    write_wav(path, np.stack([x, 0.5 * x], axis=1), channels=2)
    return path, x


@pytest.mark.parametrize(
    "name,args,container,codec",
    [
        ("a.mp3", ["-c:a", "libmp3lame"], "MP3", "mp3"),
        ("a.flac", ["-c:a", "flac"], "FLAC", "flac"),
        ("a.m4a", ["-c:a", "aac"], "M4A/MP4", "aac"),
        ("a.aac", ["-c:a", "aac", "-f", "adts"], "AAC (ADTS)", "aac"),
        ("a.ogg", ["-c:a", "libvorbis"], "Ogg", "vorbis"),
        ("a.opus", ["-c:a", "libopus"], "Ogg", "opus"),
        ("a.webm", ["-c:a", "libopus"], "WebM/Matroska", "opus"),
        ("mulaw.wav", ["-c:a", "pcm_mulaw"], "WAV", "pcm_mulaw"),
    ],
)
def test_recorded_formats_decode_to_the_mono_pcm_of_the_pipeline(
    tmp_path, name, args, container, codec
):
    src, x = _stereo_source(tmp_path)
    path = _encode(src, tmp_path / name, *args)
    a = read_audio(path, max_duration=600)
    assert a.channels == 2 and a.container == container and a.encoding == codec
    # raw ADTS has no edit list, so the encoder's priming and last-frame padding stay (~90 ms)
    assert abs(a.duration - 1.0) < (0.1 if name == "a.aac" else 0.03)
    assert (
        f"{container} ({codec})" in a.summary and "mixed to mono (mean of 2 channels)" in a.summary
    )
    # the mean of the channels is 0.75 x the left one; lossy codecs keep the level to ~1 dB
    rms = np.sqrt(np.mean(a.samples[2000:-2000] ** 2)) / np.sqrt(np.mean(x[2000:-2000] ** 2))
    assert 0.75 * 0.89 < rms < 0.75 * 1.12
    feats = features_from_samples(a.samples, a.sample_rate, fps=30)
    assert abs(np.median(feats.f0[feats.voiced]) - 150) < 2


def test_stereo_wav_is_mixed_to_mono_by_the_mean(tmp_path):
    src, x = _stereo_source(tmp_path)
    sound, channels = load_sound(src)
    assert channels == 2 and sound.n_channels == 1
    np.testing.assert_allclose(sound.values[0], 0.75 * x, atol=1e-4)
    assert check_audio_file(src).endswith("read directly, mixed to mono (mean of 2 channels)")


def _fake_ffmpeg(tmp_path: Path, monkeypatch, decode_body: str) -> None:
    """An 'ffmpeg' that reports a valid MP3 stream and then runs ``decode_body``."""
    exe = tmp_path / "ffmpeg"
    exe.write_text(
        "#!/bin/sh\n"
        'case "$*" in *-map*) ;; *)\n'
        "  echo '  Duration: 00:00:01.00, start: 0.000000, bitrate: 128 kb/s' >&2\n"
        "  echo '  Stream #0:0: Audio: mp3, 16000 Hz, mono, fltp, 128 kb/s' >&2\n"
        "  exit 1;; esac\n" + decode_body + "\n"
    )
    exe.chmod(0o755)
    monkeypatch.setattr(imageio_ffmpeg, "get_ffmpeg_exe", lambda: str(exe))


def test_a_decoder_crash_is_a_refused_file_not_a_dead_caller(tmp_path, monkeypatch):
    _fake_ffmpeg(tmp_path, monkeypatch, "kill -FPE $$")
    path = tmp_path / "a.mp3"
    path.write_bytes(b"\xff\xfb\x90\x64" + bytes(2000))
    with pytest.raises(InputError) as err:
        read_audio(path, max_duration=10)
    assert "MP3 audio could not be decoded: killed by signal 8" in _one_line_naming(err, path)


def test_a_hanging_decoder_is_stopped(tmp_path, monkeypatch):
    _fake_ffmpeg(tmp_path, monkeypatch, "exec sleep 30")
    monkeypatch.setattr(audiofile, "PROBE_TIMEOUT_S", 0.5)
    monkeypatch.setattr(audiofile, "DECODE_S_PER_S", 0.0)
    path = tmp_path / "a.mp3"
    path.write_bytes(b"\xff\xfb\x90\x64" + bytes(2000))
    with pytest.raises(InputError, match="ffmpeg took more than 0 s"):
        read_audio(path, max_duration=10)


def test_sniffing_reads_the_bytes_not_the_name():
    assert sniff_container(b"fLaC\x00\x00\x00\x22") == "FLAC"
    assert sniff_container(b"\x00\x00\x00\x20ftypM4A ") == "MP4"
    assert sniff_container(b"OggS\x00\x02") == "OGG"
    assert sniff_container(b"\xff\xf1\x50\x80") == "AAC"
    assert sniff_container(b"\xff\xff\xff\xff") is None  # bitrate index 15: no MPEG frame
    assert sniff_container(b"FORM\x00\x00\x00\x00AIFF") == "AIFF"
    id3 = b"ID3\x04\x00\x00\x00\x00\x00\x04" + b"\x00" * 4
    assert sniff_container(id3 + b"fLaC\x00\x00\x00\x22") == "FLAC"


_PREFIXES = [
    b"",
    b"RIFF\x00\x00\x00\x00WAVE",
    _wav_bytes(b"")[:36],
    _wav_bytes(b"", channels=2, width=3)[:44],
    _wav_bytes(b"", tag=3, width=4, declared=0xFFFFFFFF)[:44],
    b"RIFX\x00\x00\x00\x00WAVEfmt \x00\x00\x00\x10",
    b"fLaC",
    b"ID3\x03\x00\x00\x00\x00\x00\x00",
    b"OggS",
    b"\xff\xfb\x90\x64",
]


@pytest.mark.parametrize(
    "samples, channels",
    [
        # a signalling NaN (quiet NaNs cast without a flag; this one raised "invalid value")
        (b"\x00\x00\x81\x7f" * 800, 1),
        (struct.pack("<ff", np.inf, -np.inf) * 800, 2),  # averaged to NaN
        (struct.pack("<f", np.inf) * 800, 1),
    ],
)
def test_non_finite_float_samples_are_one_line(tmp_path, samples, channels):
    path = tmp_path / "nan.wav"
    path.write_bytes(_wav_bytes(samples, tag=3, width=4, channels=channels))
    with pytest.raises(InputError, match="non-finite samples") as err:
        load_audio(path)
    _one_line_naming(err, path)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(prefix=st.sampled_from(_PREFIXES), body=st.binary(max_size=3000))
@example(prefix=_PREFIXES[4], body=b"\x00\x00\x81\x7f")
def test_arbitrary_bytes_give_sound_or_one_line(tmp_path, prefix, body):
    path = tmp_path / "upload.wav"
    path.write_bytes(prefix + body)
    try:
        sound, channels = load_sound(path)
    except InputError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith(str(path))
    else:
        assert sound.n_samples > 0 and channels >= 1
        assert (
            np.all(np.isfinite(sound.values))
            and np.max(np.abs(sound.values)) <= audiofile.MAX_FLOAT_PEAK
        )


def test_the_checked_path_hands_praat_no_file(tmp_path, monkeypatch):
    # Praat never opens a file here: only arrays reach it.
    import parselmouth

    opened: list[object] = []
    real = parselmouth.Sound

    def spy(*args, **kwargs):
        opened.append(args[0])
        return real(*args, **kwargs)

    monkeypatch.setattr(parselmouth, "Sound", spy)
    src, _ = _stereo_source(tmp_path)
    load_sound(src)
    load_sound(_encode(src, tmp_path / "a.flac", "-c:a", "flac"))
    assert opened and all(isinstance(a, np.ndarray) for a in opened)
    assert not any(isinstance(a, str | os.PathLike) for a in opened)


def test_a_compressed_file_longer_than_the_limit_is_refused(tmp_path):
    x, _ = harmonic_glide(150, 150, 3.0)
    write_wav(tmp_path / "long.wav", x)
    mp3 = _encode(tmp_path / "long.wav", tmp_path / "long.mp3", "-c:a", "libmp3lame")
    with pytest.raises(InputError, match=r"audio is 3\.\d s long; the limit is 1 s"):
        read_audio(mp3, max_duration=1.0)


def test_the_cli_refuses_a_broken_file_with_exit_2_and_one_line(tmp_path):
    from click.testing import CliRunner

    from app.cli import main

    bad = _id3_then_noise(tmp_path / "speech.wav")
    result = CliRunner().invoke(
        main, ["stimuli", "generate", "--audio", str(bad), "--out", str(tmp_path / "out")]
    )
    assert result.exit_code == 2
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and str(bad) in lines[0] and "MP3" in lines[0]


def test_the_generate_summary_states_the_audio_conversion(tmp_path):
    from click.testing import CliRunner

    from app.cli import main

    src, _ = _stereo_source(tmp_path)
    flac = _encode(src, tmp_path / "take.flac", "-c:a", "flac")
    result = CliRunner().invoke(
        main,
        [
            "stimuli",
            "generate",
            "--audio",
            str(flac),
            "--out",
            str(tmp_path / "out"),
            "--conditions",
            "none",
        ],
    )
    assert result.exit_code == 0, result.output
    line = next(ln for ln in result.output.splitlines() if ln.startswith("  audio: "))
    assert "take.flac: FLAC (flac)" in line and "mixed to mono (mean of 2 channels)" in line
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["speech"]["audio_file"] == line.removeprefix("  audio: ")
