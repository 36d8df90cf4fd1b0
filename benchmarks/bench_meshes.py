"""Mesh conditions beside the built-in head: what a pair costs, and how tight its mosaic is.

Three clips of the demo speech (4 s, 120 frames at 30 fps), each rendered with ``render_pair``
as a study renders it (the default size, anti-aliasing, mosaic and workers), alternately, best
of ``--repeats``:

* the comparator: the built-in head beside the built-in head (FAP tracks);
* a FaceFormer-layout VOCASET sequence (5,023 vertices) beside the built-in head;
* a BIWI-layout sequence (23,370 vertices) beside the built-in head.

The meshes are the synthetic heads of ``tests/stimuli/meshes/synthetic.py`` padded to those
counts (the projects' data are not shipped). Then, per face, the mosaic's tightness over the
clip: the mean area of its blocks against the mean area of the pixels the mouth changes (the
frame drawn moving against drawn at rest, more than one level): the share of the blocks the
mouth needed.

    python benchmarks/bench_meshes.py [--size 368] [--repeats 2]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from app.stimuli.meshes.regions import speech_energy  # noqa: E402
from app.stimuli.meshes.source import MeshOptions, mesh_track  # noqa: E402
from app.stimuli.track import MotionTrack  # noqa: E402
from renderer import RenderSettings, render_pair  # noqa: E402
from renderer.api import load_faces  # noqa: E402
from renderer.faceregions import mesh_frames_of  # noqa: E402
from renderer.pipeline import _Drawer, align_tracks  # noqa: E402
from tests.stimuli.meshes.synthetic import (  # noqa: E402
    head_mesh,
    opening_from_energy,
    talking,
    write_layout,
)

DEMO = "app/data/demo/speech.wav"


def _tracks(folder: Path) -> dict[str, list[MotionTrack]]:
    opening = opening_from_energy(speech_energy(DEMO, 30.0, 120))
    t = np.arange(120) / 30.0
    built_in = MotionTrack.from_channels(
        30.0,
        {3: 300 * opening / opening.max(), 49: 4000 * np.sin(t), 48: 2000 * np.sin(0.7 * t)},
    )
    vocaset = head_mesh(n_vertices=5023)
    biwi = head_mesh(40, 48, eyes=False, n_vertices=23370)
    ff = write_layout(folder / "v", "ff", vocaset, talking(vocaset, opening), flat=True)
    bw = write_layout(folder / "b", "bw", biwi, talking(biwi, opening), flat=True, scale=0.2)
    return {
        "built-in | built-in": [built_in, built_in],
        "VOCASET mesh | built-in": [mesh_track(ff, MeshOptions(fps=30)), built_in],
        "BIWI mesh | built-in": [mesh_track(bw, MeshOptions(fps=30)), built_in],
    }


def _tightness(tracks: list[MotionTrack], settings: RenderSettings) -> list[tuple[float, float]]:
    """Per face (left, right): mean block pixels and mean pixels the mouth changes."""
    tracks = align_tracks(tracks, None)
    faces = load_faces(tracks, settings, DEMO)
    dense = [t.dense() for t in tracks]
    frames = [mesh_frames_of(t, f) for t, f in zip(tracks, faces, strict=True)]
    drawing = settings.drawing()
    args = (dense, faces, drawing["size"], drawing["antialias"], drawing["samples"])
    drawer = _Drawer(*args, drawing["background"], drawing["mosaic_block"], 0.15, None, frames)
    plain = _Drawer(*args, drawing["background"], 0, 0.15, None, frames)
    size, block = settings.size, settings.mosaic_block
    sums = np.zeros((len(tracks), 2))
    for i in range(tracks[0].n_frames):
        masked = drawer.draw(i)
        covered = np.zeros((size, size * len(tracks)), bool)
        for (x0, y0, x1, y1), cells in zip(masked.boxes, masked.cells, strict=True):
            covered[y0:y1, x0:x1] = np.repeat(np.repeat(cells, block, 0), block, 1)
        moving = [plain.face_frame(k, i, False) for k in range(len(tracks))]
        rest = [plain.face_frame(k, i, True) for k in range(len(tracks))]
        a = np.empty((size, size * len(tracks), 3), np.uint8)
        b = np.empty_like(a)
        for g, canvas in zip(plain.groups, plain.canvases, strict=True):
            canvas.draw([moving[k] for k in g], a, slots=g)
            canvas.draw([rest[k] for k in g], b, slots=g)
        changed = (np.abs(a.astype(int) - b.astype(int)) > 1).any(axis=2)
        for k in range(len(tracks)):
            side = slice(k * size, (k + 1) * size)
            sums[k] += [covered[:, side].sum(), changed[:, side].sum()]
    drawer.release()
    plain.release()
    n = tracks[0].n_frames
    return [(float(s[0] / n), float(s[1] / n)) for s in sums]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=368)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    settings = RenderSettings(size=args.size)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        clips = _tracks(folder)
        best: dict[str, float] = {}
        for _ in range(args.repeats):
            for name, tracks in clips.items():
                start = time.perf_counter()
                render_pair(*tracks, DEMO, folder / "clip.mp4", settings=settings)
                took = time.perf_counter() - start
                best[name] = min(best.get(name, np.inf), took)
        base = best["built-in | built-in"]
        print(f"render_pair, 120 frames at {args.size} px, best of {args.repeats}:")
        for name, took in best.items():
            print(
                f"  {name:26s} {took:6.2f} s  {1000 * took / 120:6.1f} ms/frame  x{took / base:.2f}"
            )
        print("mosaic, mean per frame: block pixels / pixels the mouth changes (share needed)")
        for name, tracks in clips.items():
            cells = _tightness(tracks, settings)
            parts = [f"{b:7.0f} / {c:6.0f} ({c / b:.0%})" for b, c in cells]
            print(f"  {name:26s} left {parts[0]}   right {parts[1]}")


if __name__ == "__main__":
    main()
