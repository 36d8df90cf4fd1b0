"""H.264 + AAC MP4 encoding through imageio-ffmpeg's bundled ffmpeg, fed from its own thread.

Browser-safe output: H.264 (libx264) in yuv420p, AAC audio, ``-movflags +faststart`` (the index
up front so playback starts before the download ends), frame sizes divisible by 16. The clip
length is the track length: the audio is padded with silence (``apad``) and the output is cut
at ``n_frames / fps`` (``-t``), so a short recording never ends the video early and a long one
never lengthens it (``-shortest`` alone can die on a broken pipe when the audio is short).
No input's metadata is copied (``-map_metadata -1``): the clip carries ffmpeg's own stream
handler names and nothing else a participant could read a condition from.

A second rendition for browsers without H.264 (WebKitGTK without its codec plugins, some
Linux builds of Firefox) can be written from the same frames in the same ffmpeg process: VP9
(libvpx, real-time mode) and Opus in WebM (``webm_path``), blinded the same way and with no
encoder names either (:data:`WEBM_VIDEO`). :func:`write_webm` makes one from a finished MP4
instead, for clips rendered before renditions existed (a second generation: measured in
docs/benchmarks.md, "Renditions").

Frames are written to ffmpeg's stdin by a writer thread, so GL rendering (the caller's thread)
and encoding (ffmpeg's process) overlap on two cores.
"""

from __future__ import annotations

import hashlib
import queue
import subprocess
import tempfile
import threading
from fractions import Fraction
from pathlib import Path

import numpy as np

from app.errors import InputError


def ffmpeg_exe() -> str:
    """Path of the ffmpeg binary bundled with imageio-ffmpeg."""
    import imageio_ffmpeg

    return imageio_ffmpeg.get_ffmpeg_exe()


def fps_arg(fps: float) -> str:
    """Frame rate as an exact ffmpeg rational (29.97 -> 2997/100)."""
    f = Fraction(fps).limit_denominator(1001)
    return f"{f.numerator}/{f.denominator}"


def check_audio(audio_path: str | Path | None) -> Path | None:
    """The audio path as a Path, or an InputError naming it if it is not a readable file."""
    if audio_path is None:
        return None
    p = Path(audio_path)
    if not p.is_file():
        raise InputError("audio file not found", path=p)
    return p


#: The WebM rendition's video: VP9 in libvpx's real-time mode at speed 6 and CRF 20. On a
#: 10 s pair clip at 368 px (benchmarks/bench_renditions.py, docs/benchmarks.md "Renditions")
#: it adds 2.6 s of ffmpeg CPU to the MP4's 1.5 s, at about the MP4's size and an SSIM of
#: 0.990 against the lossless frames (x264's MP4: 0.994).
WEBM_VIDEO: tuple[str, ...] = (
    "-c:v",
    "libvpx-vp9",
    "-deadline",
    "realtime",
    "-cpu-used",
    "6",
    "-crf",
    "20",
    "-b:v",
    "0",
    "-row-mt",
    "1",
    "-pix_fmt",
    "yuv420p",
)
#: The WebM rendition's audio: Opus, mono, as the MP4's AAC is.
WEBM_AUDIO: tuple[str, ...] = ("-c:a", "libopus", "-b:a", "96k", "-ac", "1")
#: The end of a cached WebM's name (renderer.cache): the encoder settings' digest, so a
#: changed setting never serves a WebM made with the old ones.
WEBM_SUFFIX = f"-{hashlib.sha256(repr(WEBM_VIDEO + WEBM_AUDIO).encode()).hexdigest()[:8]}.webm"


def _blinded() -> list[str]:
    """Output options that keep every input's tags and chapters out of the file."""
    # Nothing of the inputs' tags (an audio file's title or handler name) reaches the clip a
    # participant receives: its metadata may name what a condition is.
    return ["-map_metadata", "-1", "-map_chapters", "-1"]


def _webm_output(
    path: Path,
    *,
    audio: bool,
    threads: int,
    n_frames: int | None = None,
    duration: float | None = None,
) -> list[str]:
    """The ffmpeg output options of a WebM rendition at ``path``: VP9 (+ Opus with ``audio``),
    blinded as the MP4 and without encoder names (``bitexact``: the muxer writes its bare
    name, "Lavf", where it must name one; the streams' encoder tags are removed). With
    ``n_frames`` and ``duration`` the audio is padded and both are cut as the MP4's are."""
    args: list[str] = []
    if audio:
        args += ["-af", "apad"] if duration is not None else []
        args += [*WEBM_AUDIO, "-flags:a", "+bitexact", "-metadata:s:a", "encoder="]
    args += [*_blinded(), "-fflags", "+bitexact", *WEBM_VIDEO, "-threads", str(threads)]
    args += ["-flags:v", "+bitexact", "-metadata:s:v", "encoder="]
    if n_frames is not None and duration is not None:
        args += ["-frames:v", str(n_frames), "-t", f"{duration:.6f}"]
    # the index up front, as +faststart puts the MP4's: playback starts before the end; the
    # first track of each kind marked default, as the MP4's are
    return args + ["-cues_to_front", "1", "-default_mode", "infer", "-f", "webm", str(path)]


class ClipWriter:
    """Streams RGB frames into an MP4 (and, with ``webm_path``, a WebM rendition of the same
    frames). Use as a context manager; ``write`` copies the frame.

    ``threads``: libx264 (and libvpx) threads (0 = one per core). One is the cheapest in CPU
    time and, at a few hundred frames per second, keeps ahead of the renderer.
    """

    def __init__(
        self,
        path: str | Path,
        width: int,
        height: int,
        fps: float,
        n_frames: int,
        audio_path: str | Path | None = None,
        *,
        crf: int = 20,
        preset: str = "superfast",
        audio_bitrate: str = "128k",
        threads: int = 1,
        webm_path: str | Path | None = None,
    ) -> None:
        self.path = Path(path)
        self.webm_path = Path(webm_path) if webm_path is not None else None
        self.n_frames = n_frames
        duration = n_frames / fps
        cmd = [
            ffmpeg_exe(),
            "-y",
            "-hide_banner",
            "-loglevel",
            "error",
            "-nostdin",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgb24",
            "-s",
            f"{width}x{height}",
            "-r",
            fps_arg(fps),
            "-i",
            "-",
        ]
        if audio_path is not None:
            cmd += [
                "-i",
                str(audio_path),
                "-map",
                "0:v:0",
                "-map",
                "1:a:0",
                "-af",
                "apad",
                "-c:a",
                "aac",
                "-b:a",
                audio_bitrate,
                "-ac",
                "1",
            ]
        cmd += [
            *_blinded(),
            "-c:v",
            "libx264",
            "-threads",
            str(threads),
            "-preset",
            preset,
            "-crf",
            str(crf),
            "-pix_fmt",
            "yuv420p",
            "-frames:v",
            str(n_frames),
            "-t",
            f"{duration:.6f}",
            "-movflags",
            "+faststart",
            str(self.path),
        ]
        if self.webm_path is not None:
            # The same decoded frames (and audio) feed both encoders: one generation each.
            cmd += ["-map", "0:v:0"] + (["-map", "1:a:0"] if audio_path is not None else [])
            cmd += _webm_output(
                self.webm_path,
                audio=audio_path is not None,
                threads=threads,
                n_frames=n_frames,
                duration=duration,
            )
        self._stderr = tempfile.TemporaryFile()
        self._proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=self._stderr)
        self._queue: queue.Queue[bytes | None] = queue.Queue(maxsize=16)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._pump, daemon=True)
        self._thread.start()

    def _pump(self) -> None:
        stdin = self._proc.stdin
        assert stdin is not None
        try:
            while (item := self._queue.get()) is not None:
                stdin.write(item)
        except BaseException as exc:  # broken pipe: reported with ffmpeg's stderr on close
            self._error = exc
            while self._queue.get() is not None:
                pass
        finally:
            try:
                stdin.close()
            except OSError:
                pass

    def write(self, frame: np.ndarray) -> None:
        """Queue one (H, W, 3) uint8 frame (copied, so the caller may reuse its buffer)."""
        self._queue.put(np.ascontiguousarray(frame).tobytes())

    def close(self) -> Path:
        """Finish the file; raises ``RuntimeError`` with ffmpeg's message if encoding failed."""
        self._queue.put(None)
        self._thread.join()
        rc = self._proc.wait()
        self._stderr.seek(0)
        err = self._stderr.read().decode(errors="replace").strip()
        self._stderr.close()
        if rc != 0 or self._error is not None:
            raise RuntimeError(
                f"ffmpeg failed (exit {rc}) writing {self.path}: "
                f"{err.splitlines()[-1] if err else self._error}"
            )
        return self.path

    def abort(self) -> None:
        """Stop ffmpeg and drop the partial file."""
        self._proc.kill()
        self._queue.put(None)
        self._thread.join()
        self._proc.wait()
        self._stderr.close()
        self.path.unlink(missing_ok=True)
        if self.webm_path is not None:
            self.webm_path.unlink(missing_ok=True)

    def __enter__(self) -> ClipWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def write_webm(mp4_path: str | Path, webm_path: str | Path, *, threads: int = 1) -> Path:
    """Write the WebM rendition (:data:`WEBM_VIDEO`, :data:`WEBM_AUDIO`) of a finished MP4
    clip: its decoded frames and audio encoded again, blinded as :class:`ClipWriter`'s. For
    clips rendered before renditions existed; a clip rendered now gets its WebM from the
    frames themselves (``ClipWriter(webm_path=...)``). Written to ``*.part.webm`` and renamed,
    so a killed job leaves no half file under the final name. Returns ``webm_path``.

    Raises :class:`~app.errors.InputError` when the MP4 is missing, ``RuntimeError`` with
    ffmpeg's last line when it cannot be read.
    """
    source, out = Path(mp4_path), Path(webm_path)
    if not source.is_file():
        raise InputError("clip not found", path=source)
    listing = subprocess.run(
        [ffmpeg_exe(), "-hide_banner", "-nostdin", "-i", str(source)],
        capture_output=True,
        text=True,
    ).stderr
    audio = " Audio: " in listing
    partial = out.with_name(out.stem + ".part.webm")
    cmd = [ffmpeg_exe(), "-y", "-hide_banner", "-loglevel", "error", "-nostdin", "-i", str(source)]
    # the MP4's audio is already padded and cut to its frames: taken as it is
    cmd += ["-map", "0:v:0"] + (["-map", "0:a:0"] if audio else [])
    cmd += _webm_output(partial, audio=audio, threads=threads)
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        partial.unlink(missing_ok=True)
        err = done.stderr.strip().splitlines()
        raise RuntimeError(
            f"ffmpeg failed (exit {done.returncode}) writing {out}: {err[-1] if err else ''}"
        )
    partial.replace(out)
    return out
