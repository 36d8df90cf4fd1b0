"""The bare pipeline of ``bench_renderer.py``: the least a side-by-side clip can cost.

The same head as facepair's (every triangle of it, with the same shaders and texture) drawn
twice at the clip's size into one side-by-side target, turned a little each frame by the
view matrix alone (no deformation, no posing on the CPU, no vertex upload, no anti-aliasing,
no mosaic), read back with one glReadPixels and encoded by the same ffmpeg / x264 settings,
in one process. ``bench_renderer.py`` runs it alternately with ``render_pair`` and prints
facepair's CPU per frame as a ratio of this one's.

    python benchmarks/bare_renderer.py [--seconds 20] [--size 368]
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from renderer import RenderSettings, load_face  # noqa: E402
from renderer.camera import camera_for  # noqa: E402
from renderer.deform import about, rotation  # noqa: E402
from renderer.encode import ClipWriter  # noqa: E402
from renderer.gl import albedo_texture, context, flat_colors  # noqa: E402
from renderer.glsl import shaders  # noqa: E402
from renderer.pipeline import rig_for  # noqa: E402


def bare_pair_clip(
    settings: RenderSettings, n_frames: int, fps: float, audio: Path | None, out: Path
) -> None:
    """Write an ``n_frames`` side-by-side clip of the settings' face the bare way."""
    import moderngl

    face = load_face(settings)
    rig = rig_for(face)
    size = settings.size
    ctx = context()
    vp, eye = camera_for(rig)
    glsl = shaders(face.textured)
    prog = ctx.program(vertex_shader=glsl["vertex"], fragment_shader=glsl["fragment"])
    pos = ctx.buffer(face.vertices.astype("f4").tobytes())
    nrm = ctx.buffer(face.normals().astype("f4").tobytes())
    progs, vaos = [prog], []
    if face.textured:
        flat_prog = ctx.program(vertex_shader=glsl["vertex"], fragment_shader=glsl["flat_fragment"])
        progs.append(flat_prog)
        uv = np.asarray(face.uvs)[face.triangles]
        flat = (uv == uv[:, :1]).all(axis=(1, 2))
        uvs = ctx.buffer(np.asarray(face.uvs, "f4").tobytes())
        texture = albedo_texture(ctx, face.texture)
        texture.use(location=0)
        for program, colours, pick in (
            (flat_prog, flat_colors(face), flat),
            (prog, face.colors, ~flat),
        ):
            index = ctx.buffer(face.triangles[pick].astype("i4").tobytes())
            content = [
                (pos, "3f", "in_pos"),
                (nrm, "3f", "in_norm"),
                (ctx.buffer(colours.astype("f4").tobytes()), "4f", "in_color"),
            ]
            if "in_uv" in program:  # the flat program does not read it
                content.append((uvs, "2f", "in_uv"))
            vaos.append(ctx.vertex_array(program, content, index_buffer=index))
    else:
        index = ctx.buffer(face.triangles.astype("i4").tobytes())
        colours = ctx.buffer(face.colors.astype("f4").tobytes())
        content = [(pos, "3f", "in_pos"), (nrm, "3f", "in_norm"), (colours, "4f", "in_color")]
        vaos.append(ctx.vertex_array(prog, content, index_buffer=index))
    for program in progs:
        program["camera"].value = tuple(eye)
    fbo = ctx.framebuffer(
        ctx.renderbuffer((2 * size, size), 3), ctx.depth_renderbuffer((2 * size, size))
    )
    frame = np.empty((size, 2 * size, 3), np.uint8)
    pivot = rig.pivot
    with ClipWriter(
        out,
        2 * size,
        size,
        fps,
        n_frames,
        audio,
        crf=settings.crf,
        preset=settings.preset,
        audio_bitrate=settings.audio_bitrate,
        threads=settings.encode_threads,
    ) as writer:
        for i in range(n_frames):
            fbo.use()
            ctx.enable_only(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
            fbo.clear(*settings.background, 1.0)
            for k in range(2):  # the two faces, each turning its own way
                turn = rotation("y", 0.3 * np.sin(0.05 * i + k)) @ rotation(
                    "x", 0.1 * np.sin(0.07 * i)
                )
                mvp = (vp @ about(turn, pivot)).T.astype("f4").tobytes()
                for program in progs:
                    program["mvp"].write(mvp)
                ctx.viewport = (k * size, 0, size, size)
                for vao in vaos:
                    vao.render(moderngl.TRIANGLES)
            fbo.read_into(frame, components=3)
            writer.write(frame[::-1])
    for obj in (*vaos, *progs, pos, nrm, fbo):
        obj.release()


def cpu_seconds() -> float:
    """User + system CPU seconds of this process and its finished children."""
    me, kids = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--size", type=int, default=368)
    args = parser.parse_args()
    fps = 30.0
    n = int(args.seconds * fps)
    with tempfile.TemporaryDirectory() as d:
        before, start = cpu_seconds(), time.perf_counter()
        bare_pair_clip(RenderSettings(size=args.size), n, fps, None, Path(d) / "bare.mp4")
        wall, cpu = time.perf_counter() - start, cpu_seconds() - before
    print(
        f"bare pipeline: {n} pair frames at {args.size} px in {wall:.2f} s "
        f"({n / wall:.0f} fps), CPU per pair frame {1e3 * cpu / n:.1f} ms"
    )


if __name__ == "__main__":
    main()
