"""Audio files as people have them, decoded to checked mono PCM before any analysis sees them.

A file's bytes are untrusted: Praat's own decoders die on some of them (an MP3 renamed ``.wav``
kills the process with SIGFPE), and a header may claim far more samples than the file holds. So
no native decoder ever reads a file in this process:

- The container is identified from the first bytes (:func:`sniff_container`), never from the
  extension.
- WAV (RIFF/RIFX) with integer PCM or IEEE float samples is parsed here, in Python and numpy
  (:func:`parse_wav`): the declared data length is checked against the file's size (a cut file is
  refused, saying how much is missing) and against the duration limit before anything is
  allocated.
- Everything else (MP3, FLAC, M4A/AAC, Ogg Vorbis/Opus, WebM, AIFF, CAF, compressed WAV) is
  decoded by the ffmpeg that imageio-ffmpeg bundles, in a subprocess with a timeout and a bound on
  its output size (``-t`` and ``-fs``), to 32-bit float WAV, which :func:`parse_wav` then checks.
  A crash of ffmpeg is a refused file, not a dead caller.
- Several channels are mixed to mono by their mean, as before.

What comes out, :class:`DecodedAudio`, holds only finite float64 samples; its
:attr:`~DecodedAudio.summary` is one line stating what the file was and what was done to it.
Anything unusable raises :class:`~app.errors.InputError`, one line naming the file.

Example
-------
>>> sniff_container(b"RIFF\\x24\\x00\\x00\\x00WAVEfmt ")
'WAV'
>>> sniff_container(b"ID3\\x04\\x00\\x00\\x00\\x00\\x00\\x00" + b"\\xff\\xfb\\x90\\x64")
'MP3'
>>> sniff_container(b"this is not audio") is None
True
"""

from __future__ import annotations

import re
import struct
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.errors import InputError

#: Sample rates accepted, Hz (telephone 8 kHz up to 384 kHz studio rates; below 1 kHz is no speech).
SAMPLE_RATE_RANGE = (1000.0, 384000.0)
#: Most channels accepted (a 7.1.4 or ambisonic recording still mixes to mono).
MAX_CHANNELS = 64
#: Seconds ffmpeg may take to read a header, and per second of audio to decode (plus 30 s).
PROBE_TIMEOUT_S, DECODE_S_PER_S = 30.0, 0.25
#: Largest float sample accepted (full scale is 1; a decoder's overshoot stays far below this).
MAX_FLOAT_PEAK = 16.0
#: Frames mixed to mono per block, so a long multichannel file never sits in memory as float64.
_BLOCK_FRAMES = 1 << 20

_CONTAINER_NAMES = {
    "WAV": "WAV",
    "RF64": "RF64 WAV",
    "FLAC": "FLAC",
    "MP3": "MP3",
    "AAC": "AAC (ADTS)",
    "MP4": "M4A/MP4",
    "OGG": "Ogg",
    "WEBM": "WebM/Matroska",
    "AIFF": "AIFF",
    "CAF": "Core Audio (CAF)",
}
_EXTENSIONS = {
    "WAV": {".wav", ".wave"},
    "RF64": {".wav", ".rf64"},
    "FLAC": {".flac"},
    "MP3": {".mp3"},
    "AAC": {".aac"},
    "MP4": {".m4a", ".mp4", ".aac", ".3gp", ".mov", ".m4b"},
    "OGG": {".ogg", ".oga", ".opus"},
    "WEBM": {".webm", ".mkv", ".mka"},
    "AIFF": {".aif", ".aiff", ".aifc"},
    "CAF": {".caf"},
}
EXPECTED = "WAV, FLAC, MP3, M4A/AAC, Ogg, WebM, AIFF or CAF audio"


@dataclass(frozen=True, eq=False)
class DecodedAudio:
    """Mono float64 samples in [-1, 1] (finite) and how they were obtained.

    Attributes
    ----------
    samples : mono samples (the mean of the channels).
    sample_rate : Hz, the file's own (nothing is resampled).
    channels : the file's channel count.
    container : what the bytes are (``"WAV"``, ``"MP3"``, ``"M4A/MP4"``, ...).
    encoding : the samples' coding (``"16-bit PCM"``, ``"mp3"``, ``"aac"``, ...).
    decoder : ``"read directly"`` or ``"decoded by ffmpeg"``.
    path : the file.
    """

    samples: np.ndarray
    sample_rate: float
    channels: int
    container: str
    encoding: str
    decoder: str
    path: str

    @property
    def duration(self) -> float:
        return len(self.samples) / self.sample_rate

    @property
    def summary(self) -> str:
        """One line a caller can print: the file, what it holds and the conversion done.

        e.g. ``talk.m4a: M4A/MP4 (aac), 44100 Hz, 2 channels, 3.10 s; decoded by ffmpeg,
        mixed to mono (mean of 2 channels)``.
        """
        p = Path(self.path)
        what = self.container
        kind = next((k for k, v in _CONTAINER_NAMES.items() if v == self.container), "")
        if p.suffix and kind and p.suffix.lower() not in _EXTENSIONS.get(kind, set()):
            what += f" content in a {p.suffix} file"
        ch = "mono" if self.channels == 1 else f"{self.channels} channels"
        steps = [self.decoder]
        if self.channels > 1:
            steps.append(f"mixed to mono (mean of {self.channels} channels)")
        return (
            f"{p.name}: {what} ({self.encoding}), {self.sample_rate:g} Hz, {ch}, "
            f"{self.duration:.2f} s; " + ", ".join(steps)
        )


def sniff_container(head: bytes) -> str | None:
    """The container that a file's first bytes announce, or ``None`` for none known.

    ``head`` is the first 64 bytes or so. Magic numbers: RIFF/RIFX..WAVE and RF64 (EBU Tech
    3306), ``fLaC`` (FLAC), an MPEG audio frame header (11 set sync bits, valid layer, bitrate
    and rate indices; ISO/IEC 11172-3) or an ADTS header (ISO/IEC 13818-7), ``ftyp`` at offset 4
    (ISO base media: M4A, MP4, 3GP), ``OggS``, the EBML magic 1A 45 DF A3 (WebM, Matroska),
    FORM..AIFF/AIFC and ``caff``. An ID3v2 tag (``ID3``) is skipped and what follows it sniffed;
    a tag with nothing recognisable after it is taken as MP3, which ffmpeg then checks.
    """
    if head[:3] == b"ID3" and len(head) >= 10:
        size = _id3_size(head)
        return sniff_container(head[size:]) if len(head) > size + 4 else "MP3"
    if len(head) >= 12 and head[:4] in (b"RIFF", b"RIFX") and head[8:12] == b"WAVE":
        return "WAV"
    if len(head) >= 12 and head[:4] == b"RF64" and head[8:12] == b"WAVE":
        return "RF64"
    if head[:4] == b"fLaC":
        return "FLAC"
    if head[:4] == b"OggS":
        return "OGG"
    if head[:4] == b"\x1a\x45\xdf\xa3":
        return "WEBM"
    if head[:4] == b"caff":
        return "CAF"
    if len(head) >= 12 and head[:4] == b"FORM" and head[8:12] in (b"AIFF", b"AIFC"):
        return "AIFF"
    if len(head) >= 8 and head[4:8] == b"ftyp":
        return "MP4"
    if len(head) >= 4 and head[0] == 0xFF and head[1] & 0xE0 == 0xE0:
        if head[1] & 0x06 == 0:  # layer bits 00: ADTS AAC, whose version bit may be either
            return "AAC" if head[1] & 0xF0 == 0xF0 else None
        version, bitrate, rate = (head[1] >> 3) & 3, head[2] >> 4, (head[2] >> 2) & 3
        if version != 1 and bitrate != 15 and rate != 3:
            return "MP3"
    return None


def _id3_size(head: bytes) -> int:
    """Bytes of an ID3v2 tag: a 10-byte header, a 28-bit "syncsafe" size, a footer if flagged."""
    b = head[6:10]
    size = (b[0] & 0x7F) << 21 | (b[1] & 0x7F) << 14 | (b[2] & 0x7F) << 7 | (b[3] & 0x7F)
    return size + 10 + (10 if head[5] & 0x10 else 0)


def read_audio(
    path: str | Path,
    *,
    max_duration: float,
    min_duration: float = 0.0,
    silence_peak: float = 0.0,
) -> DecodedAudio:
    """Identify, check and decode an audio file to mono float64 samples.

    Raises :class:`InputError` (one line naming the file) for a missing or empty file, an
    unknown container, a header that does not add up, a truncated WAV, audio longer than
    ``max_duration`` or shorter than ``min_duration`` seconds, non-finite samples, or a peak
    below ``silence_peak`` (all silence).
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("no such audio file", path=p)
    size = p.stat().st_size
    if size == 0:
        raise InputError(f"empty file: expected {EXPECTED}", path=p)
    with p.open("rb") as f:
        head = f.read(64)
        kind = sniff_container(head)
        if head[:3] == b"ID3" and len(head) >= 10:  # the tag may be longer than what was read
            f.seek(_id3_size(head))
            kind = sniff_container(f.read(64)) or "MP3"
    if kind is None:
        shown = head[:8].hex(" ")
        raise InputError(
            f"not a recognised audio file (it starts with bytes {shown}); expected {EXPECTED}",
            path=p,
        )
    decoded = None
    if kind == "WAV":
        decoded = parse_wav(p, max_duration=max_duration, compressed_ok=True)
    if decoded is None:
        decoded = _decode_with_ffmpeg(p, kind, max_duration)
    _check_content(decoded, p, max_duration, min_duration, silence_peak)
    return decoded


def _check_content(
    a: DecodedAudio, p: Path, max_duration: float, min_duration: float, silence_peak: float
) -> None:
    if len(a.samples) == 0:
        raise InputError("the audio holds no samples", path=p)
    if a.duration > max_duration:
        raise InputError(
            f"audio is {a.duration:.1f} s long; the limit is {max_duration:g} s "
            "(cut it into stimuli or raise max_duration)",
            path=p,
        )
    if a.duration < min_duration:
        raise InputError(
            f"audio is {a.duration * 1000:.0f} ms long; at least "
            f"{min_duration * 1000:.0f} ms is needed for pitch analysis",
            path=p,
        )
    if silence_peak > 0 and np.max(np.abs(a.samples)) < silence_peak:
        raise InputError("the audio is all silence: no speech to analyse", path=p)


#: WAV format tags read here and their sample containers (bytes per sample).
WAV_CONTAINERS = {1: (1, 2, 3, 4), 3: (4, 8)}
_EXTENSIBLE = 0xFFFE


def parse_wav(
    path: str | Path, *, max_duration: float, compressed_ok: bool = False
) -> DecodedAudio | None:
    """Read a RIFF/RIFX WAV of integer PCM (8-32 bit) or IEEE float (32/64 bit) samples.

    Checked before any sample is read: a ``fmt `` chunk of at least 16 bytes before the data;
    1 to :data:`MAX_CHANNELS` channels; a rate in :data:`SAMPLE_RATE_RANGE`; block align =
    channels x container with bits per sample no wider than the container (Praat reads odd widths
    such as 40-bit PCM wrongly without complaint); the declared data length no longer than the
    file holds (a truncated file is refused, naming how much is missing) and within
    ``max_duration``. A data length of 0 or 0xFFFFFFFF with bytes after it is the mark of a
    streamed WAV (written before its length was known) and is read to the end of the file.

    A compressed WAV (a-law, mu-law, ADPCM, ...) returns ``None`` when ``compressed_ok``
    (ffmpeg decodes it), else is refused.
    """
    p = Path(path)
    file_size = p.stat().st_size
    with p.open("rb") as f:
        head = f.read(12)
        if len(head) < 12 or head[:4] not in (b"RIFF", b"RIFX") or head[8:12] != b"WAVE":
            raise InputError("not a RIFF WAVE file", path=p)
        endian = "<" if head[:4] == b"RIFF" else ">"
        fmt: bytes | None = None
        data_at = data_size = -1
        while data_at < 0 or fmt is None:
            chunk = f.read(8)
            if len(chunk) < 8:
                missing = "fmt" if fmt is None else "data"
                raise InputError(f"WAV file has no {missing} chunk (truncated?)", path=p)
            cid, size = chunk[:4], struct.unpack(endian + "I", chunk[4:])[0]
            if cid == b"fmt ":
                fmt = f.read(min(size, 40))
                if len(fmt) < 16 or size < 16:
                    raise InputError("WAV fmt chunk is truncated", path=p)
                f.seek(size - len(fmt) + (size & 1), 1)
            elif cid == b"data":
                data_at, data_size = f.tell(), size
                if fmt is None:
                    f.seek(size + (size & 1), 1)
            else:
                f.seek(size + (size & 1), 1)
        tag, channels, rate, _, align, bits = struct.unpack(endian + "HHIIHH", fmt[:16])
        if tag == _EXTENSIBLE and len(fmt) >= 26:
            tag = struct.unpack(endian + "H", fmt[24:26])[0]  # the sub-format GUID's first field
        if tag not in WAV_CONTAINERS:
            if compressed_ok:
                return None
            raise InputError(f"WAV format tag {tag:#06x} is not PCM or float", path=p)
        container = align // channels if channels else 0
        if (
            channels == 0
            or align % channels
            or container not in WAV_CONTAINERS[tag]
            or not 0 < bits <= 8 * container
        ):
            raise InputError(
                f"unsupported WAV sample width: {bits} bits per sample in {align}-byte frames "
                f"of {channels} channel(s); expected 8/16/24/32-bit PCM or 32/64-bit float",
                path=p,
            )
        if channels > MAX_CHANNELS:
            raise InputError(f"WAV has {channels} channels; at most {MAX_CHANNELS}", path=p)
        lo, hi = SAMPLE_RATE_RANGE
        if not lo <= rate <= hi:
            raise InputError(
                f"WAV sample rate {rate} Hz is outside {lo:g}-{hi:g} Hz (a broken header?)",
                path=p,
            )
        available = max(file_size - data_at, 0)
        if data_size in (0, 0xFFFFFFFF) and available >= align:
            data_size = available - available % align
        frames = data_size // align
        if data_size > available:
            have = available // align
            raise InputError(
                f"WAV is truncated: its header declares {frames} samples "
                f"({frames / rate:.3f} s), the file holds {have} ({have / rate:.3f} s); "
                f"{(frames - have) / rate:.3f} s ({100 * (frames - have) / frames:.0f} %) "
                "is missing",
                path=p,
            )
        if frames / rate > max_duration:
            raise InputError(
                f"audio is {frames / rate:.1f} s long; the limit is {max_duration:g} s "
                "(cut it into stimuli or raise max_duration)",
                path=p,
            )
        f.seek(data_at)
        mono = np.empty(frames, dtype=np.float64)
        # A float file may hold signalling NaNs or opposite infinities: casting and averaging
        # them raise floating-point flags, which the finite check below turns into one line.
        with np.errstate(invalid="ignore", over="ignore"):
            for start in range(0, frames, _BLOCK_FRAMES):
                n = min(_BLOCK_FRAMES, frames - start)
                raw = f.read(n * align)
                block = _pcm_to_float(raw, tag, container, endian).reshape(n, channels)
                mono[start : start + n] = block.mean(axis=1) if channels > 1 else block[:, 0]
    if not np.all(np.isfinite(mono)):
        raise InputError("the audio holds non-finite samples (NaN or infinity)", path=p)
    peak = float(np.max(np.abs(mono))) if frames else 0.0
    if peak > MAX_FLOAT_PEAK:
        raise InputError(
            f"float samples reach {peak:.3g} (full scale is 1): not audio, or a broken file",
            path=p,
        )
    encoding = f"{bits}-bit " + ("PCM" if tag == 1 else "float")
    return DecodedAudio(mono, float(rate), channels, "WAV", encoding, "read directly", str(p))


def _pcm_to_float(raw: bytes, tag: int, width: int, endian: str) -> np.ndarray:
    """Samples of one block as float64 in [-1, 1): integers over their full scale.

    8-bit WAV is unsigned (offset 128), wider integers are two's complement; bits below the
    container's width are left-justified, so the container's full scale is the right divisor.
    """
    if tag == 3:
        return np.frombuffer(raw, dtype=f"{endian}f{width}").astype(np.float64)
    if width == 1:
        return (np.frombuffer(raw, dtype=np.uint8).astype(np.float64) - 128.0) / 128.0
    if width == 3:
        b = np.frombuffer(raw, dtype=np.uint8).reshape(-1, 3).astype(np.int32)
        lo, mid, hi = (b[:, 0], b[:, 1], b[:, 2]) if endian == "<" else (b[:, 2], b[:, 1], b[:, 0])
        v = lo | (mid << 8) | (hi << 16)
        return np.where(v >= 1 << 23, v - (1 << 24), v).astype(np.float64) / float(1 << 23)
    ints = np.frombuffer(raw, dtype=f"{endian}i{width}")
    return ints.astype(np.float64) / float(1 << (8 * width - 1))


_STREAM_RE = re.compile(r"Stream #\d+:\d+[^:]*: Audio: (\w+)[^,\n]*, (\d+) Hz, ([^,\n]+)")
_DURATION_RE = re.compile(r"Duration: (\d+):(\d\d):(\d\d(?:\.\d+)?)")
_LAYOUT_CHANNELS = {"mono": 1, "stereo": 2, "2.1": 3, "3.0": 3, "quad": 4, "4.0": 4}


def _ffmpeg(p: Path, args: list[str], timeout: float, what: str) -> tuple[int, str]:
    """Run the bundled ffmpeg on ``p``; its exit status and the tail of its messages."""
    try:
        import imageio_ffmpeg

        exe = imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError) as exc:
        raise InputError(f"{what} needs ffmpeg (imageio-ffmpeg): {exc}", path=p) from None
    with tempfile.TemporaryFile() as err:
        try:
            rc = subprocess.run(
                [exe, "-nostdin", "-hide_banner", "-i", str(p), *args],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=err,
                timeout=timeout,
                check=False,
            ).returncode
        except subprocess.TimeoutExpired:
            raise InputError(f"{what}: ffmpeg took more than {timeout:.0f} s", path=p) from None
        err.seek(0, 2)
        err.seek(max(err.tell() - 16384, 0))
        return rc, err.read().decode("utf-8", "replace")


def _decode_with_ffmpeg(p: Path, kind: str, max_duration: float) -> DecodedAudio:
    """Decode the first audio stream to float WAV in a subprocess, bounded in time and size."""
    name = _CONTAINER_NAMES[kind]
    _, info = _ffmpeg(p, [], PROBE_TIMEOUT_S, f"reading the {name} header")
    stream = _STREAM_RE.search(info)
    if stream is None:
        reason = _last_error(info)
        raise InputError(f"{name} file with no readable audio stream: {reason}", path=p)
    codec, rate = stream.group(1), int(stream.group(2))
    lo, hi = SAMPLE_RATE_RANGE
    if not lo <= rate <= hi:
        raise InputError(f"{name} sample rate {rate} Hz is outside {lo:g}-{hi:g} Hz", path=p)
    layout = stream.group(3).strip()
    n = re.match(r"(\d+) channels", layout)
    channels = int(n.group(1)) if n else _LAYOUT_CHANNELS.get(layout.split("(")[0], 8)
    claimed = _DURATION_RE.search(info)
    if claimed:
        h, m, s = claimed.groups()
        seconds = 3600 * int(h) + 60 * int(m) + float(s)
        if seconds > max_duration + 1:
            raise InputError(
                f"audio is {seconds:.1f} s long; the limit is {max_duration:g} s "
                "(cut it into stimuli or raise max_duration)",
                path=p,
            )
    limit_s = max_duration + 1.0  # one second over the limit tells "too long" from "at it"
    bound = int(limit_s * rate * min(channels, MAX_CHANNELS) * 4) + 4096
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "decoded.wav"
        rc, messages = _ffmpeg(
            p,
            ["-map", "0:a:0", "-vn", "-sn", "-dn", "-t", f"{limit_s:g}", "-fs", str(bound)]
            + ["-c:a", "pcm_f32le", "-f", "wav", "-y", str(out)],
            PROBE_TIMEOUT_S + DECODE_S_PER_S * limit_s,
            f"decoding the {name} audio",
        )
        if rc != 0 or not out.is_file():
            how = f"killed by signal {-rc}" if rc < 0 else _last_error(messages)
            raise InputError(f"{name} audio could not be decoded: {how}", path=p)
        try:
            pcm = parse_wav(out, max_duration=limit_s + 1.0)
        except InputError as exc:
            raise InputError(f"{name} audio decoded badly: {exc.message}", path=p) from None
    assert pcm is not None  # ffmpeg wrote float samples
    return DecodedAudio(
        pcm.samples, pcm.sample_rate, pcm.channels, name, codec, "decoded by ffmpeg", str(p)
    )


def _last_error(messages: str) -> str:
    lines = [ln.strip() for ln in messages.splitlines() if ln.strip()]
    useful = [ln for ln in lines if not ln.startswith(("Input #", "Stream #", "Duration:"))]
    return " ".join((useful or lines or ["no message"])[-1].split())[:160]
