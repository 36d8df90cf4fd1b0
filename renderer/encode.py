"""H.264 + AAC MP4 encoding through imageio-ffmpeg's bundled ffmpeg, fed from its own thread.

Browser-safe output: H.264 (libx264) in yuv420p, AAC audio, ``-movflags +faststart`` (the index
up front so playback starts before the download ends), frame sizes divisible by 16. The clip
length is the track length: the audio is padded with silence (``apad``) and the output is cut
at ``n_frames / fps`` (``-t``), so a short recording never ends the video early and a long one
never lengthens it (``-shortest`` alone can die on a broken pipe when the audio is short).
No input's metadata is copied (``-map_metadata -1``): the clip carries ffmpeg's own stream
handler names and nothing else a participant could read a condition from.

Frames are written to ffmpeg's stdin by a writer thread, so GL rendering (the caller's thread)
and encoding (ffmpeg's process) overlap on two cores.
"""

from __future__ import annotations

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


class ClipWriter:
    """Streams RGB frames into an MP4. Use as a context manager; ``write`` copies the frame.

    ``threads``: libx264 threads (0 = one per core). One is the cheapest in CPU time and, at
    a few hundred frames per second, keeps ahead of the renderer.
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
    ) -> None:
        self.path = Path(path)
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
            # Nothing of the inputs' tags (an audio file's title or handler name) reaches the
            # clip a participant receives: its metadata may name what a condition is.
            "-map_metadata",
            "-1",
            "-map_chapters",
            "-1",
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

    def __enter__(self) -> ClipWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()
