"""Benchmark: what the WebM rendition (VP9 + Opus, for browsers without H.264) adds to a clip.

Draws the frames of a side-by-side pair clip once (two conditions' tracks over synthetic
speech, the default size, :func:`renderer.pipeline.render_frames`) and keeps them in memory,
then encodes the same frames with their audio, alternately:

- ``mp4``: the MP4 alone (``renderer.encode.ClipWriter``, x264 as the render job uses it), the
  comparator;
- ``mp4+webm``: the MP4 and the WebM from the same frames in one ffmpeg process
  (``ClipWriter(webm_path=...)``), as a render job makes them now;
- ``webm from mp4``: the WebM made from the finished MP4 (``renderer.encode.write_webm``), as
  ``facepair study renditions`` makes one for a clip rendered before renditions existed.

Prints, per variant, the median wall time and the CPU seconds of ffmpeg (this process's
children), the extra over the MP4 alone per clip and per second of clip, the file sizes, and
the SSIM of each rendition against a lossless encoding of the same frames (ffmpeg's ``ssim``
filter, Wang et al. 2004, on the Y'CbCr 4:2:0 planes both renditions use).

    python benchmarks/bench_renditions.py [--seconds 10] [--size 368] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

from renderer import RenderSettings, load_face
from renderer.encode import ClipWriter, ffmpeg_exe, write_webm
from renderer.pipeline import align_tracks, render_frames


def _children_cpu() -> float:
    """User + system CPU seconds of this process's finished children (ffmpeg)."""
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return kids.ru_utime + kids.ru_stime


def _ssim(reference: Path, clip: Path) -> float:
    """Mean SSIM (all planes) of ``clip``'s frames against ``reference``'s."""
    done = subprocess.run(
        [ffmpeg_exe(), "-hide_banner", "-nostdin", "-i", str(clip), "-i", str(reference)]
        + ["-lavfi", "ssim", "-f", "null", "-"],
        capture_output=True,
        text=True,
        check=True,
    )
    found = re.search(r"All:([0-9.]+)", done.stderr)
    if found is None:
        raise RuntimeError(f"no SSIM in ffmpeg's output for {clip}")
    return float(found.group(1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--size", type=int, default=368)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    from synthetic import write_speech  # benchmarks/synthetic.py, beside this script

    from app.stimuli.generate import generate_conditions

    settings = RenderSettings(size=args.size)
    with tempfile.TemporaryDirectory() as d:
        out = Path(d)
        wav = write_speech(out / "speech.wav", args.seconds)
        result = generate_conditions(wav, conditions=("speech_driven", "random"))
        left, right = align_tracks([result.tracks["speech_driven"], result.tracks["random"]], None)
        face = load_face(settings)
        drawing = settings.drawing()
        frames = [
            f.image.copy()
            for f in render_frames([left, right], face, **drawing, frames=range(left.n_frames))
        ]
        n, fps, width = len(frames), left.fps, 2 * args.size

        def encode(path: Path, *, webm: Path | None = None, crf: int = settings.crf) -> None:
            with ClipWriter(
                path,
                width,
                args.size,
                fps,
                n,
                wav,
                crf=crf,
                preset=settings.preset,
                audio_bitrate=settings.audio_bitrate,
                threads=settings.encode_threads,
                webm_path=webm,
            ) as writer:
                for image in frames:
                    writer.write(image)

        variants = {
            "mp4": lambda: encode(out / "a.mp4"),
            "mp4+webm": lambda: encode(out / "b.mp4", webm=out / "b.webm"),
            "webm from mp4": lambda: write_webm(out / "a.mp4", out / "c.webm"),
        }
        wall: dict[str, list[float]] = {k: [] for k in variants}
        cpu: dict[str, list[float]] = {k: [] for k in variants}
        for _ in range(args.repeat):
            for name, run in variants.items():
                before, start = _children_cpu(), time.perf_counter()
                run()
                wall[name].append(time.perf_counter() - start)
                cpu[name].append(_children_cpu() - before)
        encode(out / "lossless.mp4", crf=0)

        clip = n / fps
        print(
            f"pair clip {clip:.1f} s, {n} frames at {fps:g} fps, {width}x{args.size}, with "
            f"audio; x264 {settings.preset} crf {settings.crf}, {settings.encode_threads} "
            f"encoder thread(s); {args.repeat} rounds, {os.cpu_count()} cores, load "
            f"{' '.join(f'{x:.1f}' for x in os.getloadavg())} at the end"
        )
        base_wall, base_cpu = statistics.median(wall["mp4"]), statistics.median(cpu["mp4"])
        sizes = {
            "mp4": out / "a.mp4",
            "mp4+webm": out / "b.webm",
            "webm from mp4": out / "c.webm",
        }
        for name in variants:
            w, c = statistics.median(wall[name]), statistics.median(cpu[name])
            if name == "mp4":
                extra = ""
            elif name == "mp4+webm":
                extra = (
                    f"; extra over the MP4 alone: {w - base_wall:+.2f} s wall, "
                    f"{c - base_cpu:+.2f} s CPU per clip ({(c - base_cpu) / clip:.3f} s CPU "
                    "per second of clip)"
                )
            else:
                extra = f"; {c / clip:.3f} s CPU per second of clip"
            print(
                f"{name:>14}: median {w:.2f} s wall, {c:.2f} s ffmpeg CPU; "
                f"{sizes[name].name} {sizes[name].stat().st_size / 1e3:.0f} kB, SSIM "
                f"{_ssim(out / 'lossless.mp4', sizes[name]):.4f}{extra}"
            )


if __name__ == "__main__":
    main()
