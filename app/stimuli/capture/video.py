"""Grey frames and their time stamps from any video imageio's ffmpeg reads.

The thesis' capture card delivered 29.97 frames a second and a copy of a frame was inserted
now and then to make 30 (sec. 3.1.2): a frame's number is not its time. Each frame's
presentation time stamp is read from ffmpeg (its ``showinfo`` filter) with frames passed
through as stored (``-fps_mode passthrough``: nothing dropped or duplicated to reach a
constant rate), so :func:`app.stimuli.capture.timeline.to_track` can place every sample at
its time.

Example
-------
>>> meta = video_info("clip.mp4")                            # doctest: +SKIP
>>> for t, grey in read_grey_frames("clip.mp4", meta): ...   # doctest: +SKIP
"""

from __future__ import annotations

import re
import subprocess
import threading
from collections.abc import Iterator
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError

_PTS = re.compile(rb"\bn:\s*(\d+)\s+pts:\s*-?\d+\s+pts_time:\s*(-?[\d.]+)")


_VIDEO = re.compile(r"Stream #\S+.*?Video: .*?[ ,](\d{1,5})x(\d{1,5})(?![\dA-Fa-fx])")
_FPS = re.compile(r"(\d+(?:\.\d+)?) (?:fps|tbr)")
_DURATION = re.compile(r"Duration: (\d+):(\d+):(\d+(?:\.\d+)?)")


def video_info(path: str | Path) -> dict[str, Any]:
    """``size`` (width, height), ``fps`` and ``n_frames`` (an estimate) from ffmpeg's header."""
    import imageio_ffmpeg

    p = Path(path)
    if not p.is_file():
        raise InputError("video file not found", path=p)
    probe = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostdin", "-i", str(p)],
        capture_output=True,
        text=True,
        errors="replace",
    )
    video = _VIDEO.search(probe.stderr)
    if video is None:
        lines = probe.stderr.strip().splitlines()
        reason = lines[-1] if lines else "no video stream"
        raise InputError(f"not a video ffmpeg can read ({reason})", path=p)
    fps = _FPS.search(probe.stderr[video.start() :])
    rate = float(fps.group(1)) if fps else 0.0
    duration = _DURATION.search(probe.stderr)
    seconds = (
        (3600 * int(duration.group(1)) + 60 * int(duration.group(2)) + float(duration.group(3)))
        if duration
        else 0.0
    )
    return {
        "size": (int(video.group(1)), int(video.group(2))),
        "fps": rate,
        "n_frames": int(round(seconds * rate)),
    }


def read_grey_frames(
    path: str | Path, info: dict[str, Any] | None = None
) -> Iterator[tuple[float, np.ndarray]]:
    """``(time stamp in seconds, (h, w) uint8 luma)`` for every stored frame, in order."""
    import imageio_ffmpeg

    info = info or video_info(path)
    width, height = info["size"]
    cmd = [
        imageio_ffmpeg.get_ffmpeg_exe(),
        "-hide_banner",
        "-nostdin",
        "-i",
        str(path),
        "-map",
        "0:v:0",
        "-fps_mode",
        "passthrough",
        "-vf",
        "showinfo",
        "-f",
        "rawvideo",
        "-pix_fmt",
        "gray",
        "-",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    stamps: list[float] = []
    log: list[bytes] = []
    ready = threading.Condition()

    def read_log() -> None:
        assert proc.stderr is not None
        for line in proc.stderr:
            m = _PTS.search(line)
            with ready:
                if m:
                    stamps.append(float(m.group(2)))
                else:
                    log.append(line)
                ready.notify_all()
        with ready:
            stamps.append(float("nan"))  # end of the log
            ready.notify_all()

    thread = threading.Thread(target=read_log, daemon=True)
    thread.start()
    size = width * height
    assert proc.stdout is not None
    try:
        k = 0
        while len(data := proc.stdout.read(size)) == size:
            with ready:
                ready.wait_for(partial(_has_more, stamps, k))
                t = stamps[k]
            if not np.isfinite(t):
                raise InputError(f"frame {k}: no time stamp from ffmpeg", path=path)
            yield t, np.frombuffer(data, np.uint8).reshape(height, width)
            k += 1
    finally:
        proc.kill()
        proc.wait()
        thread.join()
        proc.stdout.close()
        if proc.stderr is not None:
            proc.stderr.close()
    if k == 0:
        tail = b"".join(log[-3:]).decode(errors="replace").strip().splitlines()
        raise InputError(f"no frames decoded ({tail[-1] if tail else 'empty video'})", path=path)


def _has_more(stamps: list[float], k: int) -> bool:
    """Whether the time stamp of frame ``k`` has arrived."""
    return len(stamps) > k
