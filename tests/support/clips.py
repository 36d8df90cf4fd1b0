"""Rendered clips for the renderer's tests: two tracks that move differently, to render, and an
MP4 or WebM decoded back into its metadata and frames with the bundled ffmpeg. Nothing here is
part of the application."""

from __future__ import annotations

import re
import subprocess

import imageio_ffmpeg
import numpy as np

from app.stimuli.track import MotionTrack


def moving_tracks(n=45):
    """Two 30 fps motion tracks of ``n`` frames that move differently: the jaw and the head's
    yaw in the first, the jaw and the left inner eyebrow in the second."""
    t = np.arange(n) / 30.0
    a = MotionTrack.from_channels(30.0, {3: 300 + 300 * np.sin(9 * t), 49: 20000 * np.sin(t)})
    b = MotionTrack.from_channels(30.0, {3: 250 + 250 * np.sin(6 * t), 31: 100 * t})
    return a, b


def decode(path):
    """(metadata, frames) of an MP4, decoded with the bundled ffmpeg."""
    exe = imageio_ffmpeg.get_ffmpeg_exe()
    info = subprocess.run(
        [exe, "-hide_banner", "-i", str(path)], capture_output=True, text=True
    ).stderr
    video = next(line for line in info.splitlines() if "Video:" in line)
    size = tuple(int(x) for x in re.search(r", (\d+)x(\d+)", video).groups())
    meta = {
        "codec": video.split("Video:")[1].split()[0],
        "size": size,
        "fps": float(re.search(r"([\d.]+) fps", video).group(1)),
        "pix_fmt": "yuv420p" if "yuv420p" in video else video,
    }
    raw = subprocess.run(
        [exe, "-v", "error", "-i", str(path), "-f", "rawvideo", "-pix_fmt", "rgb24", "-"],
        capture_output=True,
        check=True,
    ).stdout
    frames = np.frombuffer(raw, np.uint8).reshape(-1, size[1], size[0], 3)
    return meta, list(frames)
