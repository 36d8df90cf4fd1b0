"""Benchmark: a 60 s side-by-side clip at the default size (368 px per face) with audio.

Generates two conditions' tracks (speech-driven and Perlin prosody) for 60 s of synthetic speech,
then renders and encodes the pair clip with :func:`renderer.render_pair` (GL drawing in worker
processes, H.264 + AAC encoding in ffmpeg's, overlapped) and prints frames per second, the
ratio to real time (target: at least 4x faster than real time on a 2-core CPU machine) and the
CPU time per frame of this process and its children, and that CPU as a ratio of the bare
pipeline's (``benchmarks/bare_renderer.py``: the same head drawn twice, one read-back, the same
x264 settings), run alternately with it. Then the parts alone, in this process:
deformation, drawing (GL + read-back), mosaic, and encoding of the same frames.

The built-in head is measured in each of its looks in the same run (``--look``, default both:
``plain``, the per-vertex colours, then ``textured``, the default), so the two compare on the
same load; the runs of the looks alternate, and best and median are per look.

    python benchmarks/bench_renderer.py [--seconds 60] [--size 368] [--repeat 2] [--warmup 1]
                                        [--antialias edges] [--samples 4] [--workers 0]
                                        [--face avatar.glb] [--look plain,textured]

``--face`` measures a face file or glTF avatar instead of the built-in head (e.g. the head
written by ``facepair face export``).

The drawing processes are spawned, so each imports this script again as ``__mp_main__``: the
speech analysis and condition generation it needs for its tracks are imported in ``main()``
only, so that the workers pay for the renderer's imports alone, as they do under ``facepair
render`` or a render job (the generator's imports cost each worker about 1.4 s of CPU, 1.5 ms
a pair frame of the 60 s clip, which the clip's figure used to include).
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from renderer import RenderSettings, load_face, render_pair
from renderer.encode import ClipWriter
from renderer.gl import ANTIALIAS_MODES, device_name
from renderer.pipeline import align_tracks, render_frames, rig_for


def _cpu_seconds() -> tuple[float, float]:
    """User + system CPU seconds of this process and of its finished children."""
    me, kids = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return me.ru_utime + me.ru_stime, kids.ru_utime + kids.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--size", type=int, default=368)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument(
        "--warmup", type=int, default=1, help="rounds run first and not counted (caches, imports)"
    )
    parser.add_argument("--antialias", choices=ANTIALIAS_MODES, default=RenderSettings.antialias)
    parser.add_argument("--samples", type=int, default=RenderSettings.samples)
    parser.add_argument("--workers", type=int, default=RenderSettings.workers)
    parser.add_argument("--face", default=None)
    parser.add_argument(
        "--look",
        default="plain,textured",
        help="looks of the built-in head to measure, comma-separated",
    )
    args = parser.parse_args()
    # here, not at the top: see the module's docstring
    from bare_renderer import bare_pair_clip  # the comparator, beside this script
    from synthetic import write_speech  # benchmarks/synthetic.py, beside this script

    from app.stimuli.generate import generate_conditions

    looks = args.look.split(",") if args.face is None else [RenderSettings.look]
    with tempfile.TemporaryDirectory() as d:
        wav = write_speech(Path(d) / "speech.wav", args.seconds)
        result = generate_conditions(wav, conditions=("speech_driven", "random"))
        left, right = align_tracks([result.tracks["speech_driven"], result.tracks["random"]], None)
        every = {
            look: RenderSettings(
                size=args.size,
                antialias=args.antialias,
                samples=args.samples,
                workers=args.workers,
                face=args.face,
                look=look,
            )
            for look in looks
        }
        runs: dict[str, tuple[list[float], list[list[float]]]] = {k: ([], []) for k in looks}
        bare: list[float] = []  # CPU seconds of the bare pipeline's clip, per round
        bare_wall: list[float] = []
        for r in range(-args.warmup, args.repeat):  # rounds below 0 are the warm-up
            for look, settings in every.items():
                before = _cpu_seconds()
                start = time.perf_counter()
                render_pair(left, right, wav, Path(d) / f"pair{max(r, 0)}.mp4", settings=settings)
                if r >= 0:
                    runs[look][0].append(time.perf_counter() - start)
                    runs[look][1].append(
                        [b - a for a, b in zip(before, _cpu_seconds(), strict=True)]
                    )
            # the comparator, alternating with facepair so both meet the same load
            before = _cpu_seconds()
            start = time.perf_counter()
            bare_pair_clip(every[looks[-1]], left.n_frames, left.fps, wav, Path(d) / "bare.mp4")
            if r >= 0:
                bare_wall.append(time.perf_counter() - start)
                bare.append(sum(_cpu_seconds()) - sum(before))
        print(
            f"device: {device_name()} (EGL; GLCONTEXT_DEVICE_INDEX="
            f"{os.environ.get('GLCONTEXT_DEVICE_INDEX', 'unset')})"
        )
        bare_ms = 1e3 * float(np.median(bare)) / left.n_frames
        print(
            f"bare pipeline ({looks[-1]} head drawn twice, one read-back, same x264 settings, "
            f"benchmarks/bare_renderer.py): CPU per pair frame {bare_ms:.1f} ms "
            f"(rounds: {', '.join(f'{1e3 * b / left.n_frames:.1f}' for b in bare)}), "
            f"best {left.n_frames / left.fps / min(bare_wall):.1f}x real time; "
            f"{args.repeat} rounds after {args.warmup} warm-up, load "
            f"{' '.join(f'{x:.1f}' for x in os.getloadavg())} at the end"
        )
        for look, settings in every.items():
            _report(args, left, right, wav, Path(d), look, settings, *runs[look], bare_ms)


def _report(
    args,
    left,
    right,
    wav: Path,
    d: Path,
    look: str,
    settings: RenderSettings,
    times: list[float],
    cpu: list[list[float]],
    bare_ms: float,
) -> None:
    """Print the figures of one look: the clip's, then its parts' alone."""
    n, fps = left.n_frames, left.fps
    clip_seconds = n / fps
    best, median = min(times), float(np.median(times))
    own, children = (1e3 * float(np.median(c)) / n for c in zip(*cpu, strict=True))
    size_mb = (d / "pair0.mp4").stat().st_size / 1e6
    face_name = args.face or f"built-in ({look})"
    aa = settings.antialias + (f" x{settings.samples}" if settings.antialias == "msaa" else "")
    print(
        f"face {face_name}, antialias {aa}, workers {settings.workers or 'auto'}, "
        f"x264 {settings.preset}: "
        f"pair clip {clip_seconds:.0f} s, {n} frames at {fps:g} fps, "
        f"{2 * args.size}x{args.size}, with audio ({size_mb:.1f} MB): "
        f"best {best:.2f} s = {n / best:.0f} fps = {clip_seconds / best:.1f}x real time; "
        f"median {median:.2f} s = {clip_seconds / median:.1f}x real time (target >= 4x)"
    )
    per_round = [1e3 * sum(c) / n for c in cpu]
    print(
        f"CPU per pair frame: {own + children:.1f} ms ({own:.1f} this process, "
        f"{children:.1f} workers + ffmpeg) = {(own + children) / bare_ms:.2f}x the bare "
        f"pipeline's (rounds: {', '.join(f'{p / bare_ms:.2f}x' for p in per_round)}; "
        f"goal <= 1.15x)"
    )

    # the parts alone, on the first 600 frames
    k = min(n, 600)
    face = load_face(settings)
    rig = rig_for(face)
    dense = [left.dense(), right.dense()]
    start = time.perf_counter()
    for i in range(k):
        rig.deform(dense[0][i])
        rig.deform(dense[1][i])
    deform = (time.perf_counter() - start) / k
    frames = []
    start = time.perf_counter()
    drawing = {**settings.drawing(), "mosaic_block": 0}
    for frame in render_frames([left, right], face, **drawing, frames=range(k)):
        frames.append(frame.image.copy())
    draw = (time.perf_counter() - start) / k - deform
    from renderer.mosaic import pixelate

    image = frames[0].copy()
    start = time.perf_counter()
    for _ in range(k):
        pixelate(image, (96, 216, 264, 312), settings.mosaic_block)
        pixelate(image, (96 + args.size, 216, 264 + args.size, 312), settings.mosaic_block)
    mosaic = (time.perf_counter() - start) / k
    start = time.perf_counter()
    with ClipWriter(
        Path(d) / "enc.mp4",
        2 * args.size,
        args.size,
        fps,
        k,
        wav,
        crf=settings.crf,
        preset=settings.preset,
        threads=settings.encode_threads,
    ) as writer:
        for image in frames:
            writer.write(image)
    encode = (time.perf_counter() - start) / k
    print(
        f"parts per pair frame: deform {deform * 1e3:.2f} ms, draw + read-back "
        f"{draw * 1e3:.2f} ms, mosaic {mosaic * 1e3:.2f} ms, encode alone "
        f"{encode * 1e3:.2f} ms ({1 / encode:.0f} fps)"
    )


if __name__ == "__main__":
    main()
