"""Headless OpenGL drawing of posed faces with moderngl (EGL; Mesa llvmpipe or a GPU).

One :class:`FaceCanvas` draws one or more faces side by side and returns one frame: fixed
perspective camera framed on the face's own feature points (:mod:`renderer.camera`), two lights
with Blinn-Phong shading computed per vertex in linear light (:mod:`renderer.glsl`), neutral
grey background, and anti-aliasing by discontinuity edge overdraw (:mod:`renderer.edges`; the
default) or by multisampling. Vertices arrive posed in world space
(:meth:`renderer.deform.Rig.posed`), so nothing but vertex data changes between draws: on Mesa's
llvmpipe a uniform change between the faces of a frame costs more than drawing them. Each face
is drawn alone into one square target, so its pixels do not depend on its side (A|B and B|A are
exact mirrors of each other).
"""

from __future__ import annotations

import threading

import numpy as np

import renderer.defaults as defaults
from app.errors import InputError
from renderer.camera import camera_for
from renderer.deform import FaceFrame, Rig
from renderer.edges import EdgeTable, edge_table, overdraw_edges
from renderer.egldevice import device_index
from renderer.face import Face
from renderer.glsl import shaders

#: Anti-aliasing modes (see :class:`FaceCanvas`).
ANTIALIAS_MODES: tuple[str, ...] = ("edges", "msaa", "none")


def check_antialias(mode: str) -> None:
    """An InputError naming the ``antialias`` field unless ``mode`` is one of the modes."""
    if mode not in ANTIALIAS_MODES:
        raise InputError(
            f"must be one of {', '.join(ANTIALIAS_MODES)}, got {mode!r}", field="antialias"
        )


_CONTEXTS: dict[int, object] = {}


class GLUnavailable(InputError):
    """No OpenGL context could be made; the message says what to install."""


def context():
    """The calling thread's headless moderngl context (created on first use), on the EGL
    device :func:`renderer.egldevice.device_index` picks: a GPU where there is one."""
    key = threading.get_ident()
    if key not in _CONTEXTS:
        try:
            import moderngl

            index = device_index()
            kwargs = {} if index is None else {"device_index": index}
            _CONTEXTS[key] = moderngl.create_standalone_context(backend="egl", **kwargs)
        except InputError:
            raise  # an override that names no device: its message says which there are
        except Exception as exc:  # the backends raise assorted types
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise GLUnavailable(
                "no OpenGL context could be made (headless EGL): install Mesa's EGL and "
                "software rasteriser (Debian: apt-get install libegl1 libgl1-mesa-dri) or a "
                f"GPU driver with EGL; the backend said: {reason}"
            ) from None
    return _CONTEXTS[key]


#: Mesa's CPU rasterisers, as they name themselves in GL_RENDERER.
SOFTWARE_RENDERERS: tuple[str, ...] = ("llvmpipe", "softpipe", "swrast", "lavapipe")


def device_name() -> str:
    """The GL_RENDERER string of this thread's context: the device frames are drawn on.

    The first non-software EGL device is taken (:mod:`renderer.egldevice`); set
    ``FACEPAIR_GL_DEVICE`` (``auto``, ``gpu``, ``software`` or an index) or glcontext's
    ``GLCONTEXT_DEVICE_INDEX`` to choose another (both inherited by the worker processes; see
    docs/reference/renderer.md, "On a GPU")."""
    return str(context().info["GL_RENDERER"])


def is_software(name: str) -> bool:
    """Whether a GL_RENDERER string names a CPU rasteriser rather than a GPU."""
    return any(s in name.lower() for s in SOFTWARE_RENDERERS)


def flat_colors(face, *, alpha: bool = False) -> np.ndarray:
    """A textured face's vertex colours times the texel at each vertex's UV (the nearest, as
    the texture's wrap takes it), for the triangles drawn without the texture; ``alpha``:
    that texel's coverage instead (0..1, 1 for an RGB texture)."""
    tex = np.asarray(face.texture, dtype=np.float32) / 255.0
    h, w = tex.shape[:2]
    uv = np.asarray(face.uvs, dtype=np.float64)
    cols = np.floor(uv[:, 0] % 1.0 * w).astype(int) % w
    rows = np.clip(np.floor(uv[:, 1] * h).astype(int), 0, h - 1)
    if alpha:
        return tex[rows, cols, 3] if tex.shape[2] == 4 else np.ones(len(uv), np.float32)
    out = np.array(face.colors, dtype=np.float32)
    out[:, :3] *= tex[rows, cols, :3]
    return out


#: Mipmap levels below the texture's own (:func:`albedo_texture`).
MIPMAP_LEVELS = 3


def albedo_texture(ctx, pixels: np.ndarray):
    """A mipmapped RGB texture of ``pixels`` (h, w, 3) uint8 (RGBA for (h, w, 4): an avatar's
    cut-outs), row 0 at v = 0.

    Mipmaps, as the head's texels are finer than its pixels at 368 px (pores and brow hairs
    would shimmer as the head moves); bilinear within the nearest level, which llvmpipe
    samples at nearly the cost of plain bilinear filtering. Three levels at most: at a
    grazing silhouette a coarser level would average texels from regions of the texture
    that are far apart on the head (a hair outline flickered in skin colour). Repeats across
    u (the head's azimuth wraps round), clamps in v.
    """
    import moderngl

    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    texture = ctx.texture((pixels.shape[1], pixels.shape[0]), pixels.shape[2], pixels.tobytes())
    texture.build_mipmaps(max_level=MIPMAP_LEVELS)
    texture.filter = (moderngl.LINEAR_MIPMAP_NEAREST, moderngl.LINEAR)
    texture.repeat_x, texture.repeat_y = True, False
    return texture


def drawing_order(face: Face, cutout: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The triangles a canvas draws, the same in drawing order, and where the order's four
    runs end (cumulative counts).

    A textured face's triangles whose corners share one UV (eyes, teeth, neck, clothes on the
    built-in head: half its pixels) show one texel: they are drawn without the texture
    fetch, which is most of what the texture costs on llvmpipe, and on a cut-out texel not
    at all. The order is flat, then textured, so a pass is at most two draws; the inside of
    the mouth (cavity, teeth, tongue) comes at both ends, so a face whose lips are closed,
    where none of it can show, is drawn without it (:meth:`FaceCanvas.draw`).
    """
    flat = np.zeros(face.n_triangles, bool)
    triangles = face.triangles
    if face.textured:
        uv = np.asarray(face.uvs)[face.triangles]
        flat = (uv == uv[:, :1]).all(axis=(1, 2))
        if cutout:
            drawn = ~flat | (flat_colors(face, alpha=True)[triangles[:, 0]] >= 0.5)
            triangles, flat = triangles[drawn], flat[drawn]
    inside = np.zeros(face.n_vertices, bool)
    inside[face.groups.get("mouth_interior", [])] = True
    interior = inside[triangles].all(axis=1)
    order = [flat & interior, flat & ~interior, ~flat & ~interior, ~flat & interior]
    ordered = np.concatenate([triangles[m] for m in order])
    return triangles, ordered, np.cumsum([int(m.sum()) for m in order])


class FaceCanvas:
    """Draws ``n_faces`` copies of one rigged face side by side and reads the frame back.

    ``antialias``: ``"edges"`` (discontinuity edge overdraw, :mod:`renderer.edges`; the
    default, cheap on a CPU rasteriser), ``"msaa"`` (``samples``-fold multisampling, the
    better choice on a GPU) or ``"none"``.
    """

    def __init__(
        self,
        rig: Rig,
        size: int,
        n_faces: int = 1,
        *,
        antialias: str = defaults.ANTIALIAS,
        samples: int = defaults.SAMPLES,
        background: tuple[float, float, float] = defaults.BACKGROUND,
    ) -> None:
        import moderngl

        check_antialias(antialias)
        self.ctx = ctx = context()
        self.rig, self.size, self.n_faces = rig, size, n_faces
        self.background = background
        self.vp, self.camera = camera_for(rig)
        face = rig.face
        cutout = face.textured and np.asarray(face.texture).shape[2] == 4
        glsl = shaders(face.textured, cutout)
        self.prog = ctx.program(vertex_shader=glsl["vertex"], fragment_shader=glsl["fragment"])
        self.static = ctx.buffer(face.colors.astype("f4").tobytes())
        self.texture = self.uv_buffer = None
        if face.uvs is not None and face.texture is not None:
            self.uv_buffer = ctx.buffer(np.asarray(face.uvs, "f4").tobytes())
            self.texture = albedo_texture(ctx, face.texture)
        triangles, ordered, ends = drawing_order(face, cutout)
        self.index = ctx.buffer(ordered.astype("i4").tobytes())
        #: the triangles of a face with its lips closed: all but the inside of the mouth
        self.closed_mouth = (int(ends[0]), int(ends[2]))
        self.dynamic = [
            (
                ctx.buffer(reserve=face.n_vertices * 3 * 4),
                ctx.buffer(reserve=face.n_vertices * 3 * 4),
            )
            for _ in range(n_faces)
        ]
        self.vaos = [
            self._vertex_array(self.prog, pos, nrm, self.index) for pos, nrm in self.dynamic
        ]
        #: per face, (first, end, vertex array) runs of triangles in drawing order
        self.n_triangles = len(triangles)
        self.runs = [[(0, self.n_triangles, vao)] for vao in self.vaos]
        programs = [self.prog]
        if face.textured:
            programs.append(self._flat_pass(glsl, ends))
        self.edges: EdgeTable | None = None
        if antialias == "edges":
            programs.append(self._edge_pass(glsl, triangles))
        for prog in programs:
            prog["mvp"].write(self.vp.T.astype("f4").tobytes())
            prog["camera"].value = tuple(self.camera)
        self._framebuffers(samples if antialias == "msaa" and samples > 1 else 0)
        self._modes = (
            moderngl.DEPTH_TEST | moderngl.CULL_FACE,
            moderngl.DEPTH_TEST | moderngl.BLEND,
            moderngl.TRIANGLES,
        )
        self.last_edges = [0] * n_faces  # edges overdrawn per face in the last draw

    def _flat_pass(self, glsl: dict[str, str], ends: np.ndarray):
        """The program and vertex arrays of a textured face's flat triangles (their texel in
        the vertex colour, no fetch), which draw the first runs of :func:`drawing_order`."""
        self.flat_static = self.ctx.buffer(flat_colors(self.rig.face).astype("f4").tobytes())
        self.flat_prog = self.ctx.program(
            vertex_shader=glsl["vertex"], fragment_shader=glsl["flat_fragment"]
        )
        self.flat_vaos = [
            self._vertex_array(self.flat_prog, pos, nrm, self.index, colors=self.flat_static)
            for pos, nrm in self.dynamic
        ]
        self.runs = [
            [(0, ends[1], fv), (ends[1], ends[3], v)]
            for v, fv in zip(self.vaos, self.flat_vaos, strict=True)
        ]
        return self.flat_prog

    def _edge_pass(self, glsl: dict[str, str], triangles: np.ndarray):
        """The edge table, program and vertex arrays of the discontinuity edge overdraw
        (:mod:`renderer.edges`) over the drawn ``triangles``."""
        face, size = self.rig.face, self.size
        hidden = np.zeros(face.n_vertices, bool)
        hidden[face.groups.get("hidden_outline", [])] = True
        self.edges = edges = edge_table(triangles, hidden)
        self.triangles = np.asfortranarray(triangles, dtype=np.intp)
        self.edge_prog = self.ctx.program(
            vertex_shader=glsl["vertex"],
            geometry_shader=glsl["edge_geometry"],
            fragment_shader=glsl["edge_fragment"],
        )
        self.edge_prog["half_size"].value = (size / 2.0, size / 2.0)
        self.edge_index = self.ctx.buffer(reserve=max(len(edges.a), 1) * 3 * 4)
        self.edge_vaos = [
            self._vertex_array(self.edge_prog, pos, nrm, self.edge_index)
            for pos, nrm in self.dynamic
        ]
        # clip-space x, y, w of world points: rows 0, 1 and 3 of the view-projection
        self._xyw = self.vp[[0, 1, 3]].T.astype(np.float32)
        return self.edge_prog

    def _framebuffers(self, samples: int) -> None:
        """The target a face is drawn into (multisampled when ``samples``), the one it is
        resolved into and read from, and the host buffers of one face and of the frame."""
        ctx, size = self.ctx, self.size
        self.samples = samples
        self.fbo = ctx.framebuffer(
            ctx.renderbuffer((size, size), 3, samples=self.samples),
            ctx.depth_renderbuffer((size, size), samples=self.samples),
        )
        self.resolved = (
            ctx.framebuffer(ctx.renderbuffer((size, size), 3)) if self.samples else self.fbo
        )
        self.face_buffer = np.empty((size, size, 3), np.uint8)
        self.background_u8 = np.round(np.asarray(self.background) * 255).astype(np.uint8)
        self.buffer = np.empty((size, size * self.n_faces, 3), np.uint8)

    def _vertex_array(self, prog, pos, nrm, index, colors=None):
        content = [
            (pos, "3f", "in_pos"),
            (nrm, "3f", "in_norm"),
            (colors or self.static, "4f", "in_color"),
        ]
        if self.uv_buffer is not None and "in_uv" in prog:
            content.append((self.uv_buffer, "2f", "in_uv"))
        return self.ctx.vertex_array(prog, content, index_buffer=index)

    def _render(self, k: int, first: int, end: int) -> None:
        """Draw face ``k``'s triangles ``first`` to ``end`` (in drawing order)."""
        for a, b, vao in self.runs[k]:
            lo, hi = max(a, first), min(b, end)
            if hi > lo:
                vao.render(self._modes[2], vertices=3 * (hi - lo), first=3 * lo)

    def draw(
        self,
        frames: list[FaceFrame],
        out: np.ndarray | None = None,
        *,
        lips_closed: bool = False,
        slots: list[int] | None = None,
    ) -> np.ndarray:
        """Draw one frame per face (left to right) into ``out`` (default: a buffer reused by the
        next draw); returns the (H, W, 3) uint8 frame, top row first.

        ``lips_closed``: every frame has its jaw and lip FAPs at zero (the mouth at rest the
        mosaic shows), so the inside of the mouth (the ``mouth_interior`` group) is hidden
        behind the lips and not drawn: the same pixels, a thousand triangles fewer.
        ``slots``: the side (0 = left) of ``out`` each face goes to (default: in turn), for a
        pair whose faces are drawn by two canvases (two meshes).
        """
        ctx, size = self.ctx, self.size
        solid = self._modes[0]
        out = self.buffer if out is None else out
        if self.texture is not None:  # another canvas of this context may have bound its own
            self.texture.use(location=0)
        first, end = self.closed_mouth if lips_closed else (0, self.n_triangles)
        for k, frame in enumerate(frames):
            positions, normals = self.rig.posed(frame)
            self.dynamic[k][0].write(positions)
            self.dynamic[k][1].write(normals)
            self.fbo.use()
            ctx.enable_only(solid)
            ctx.viewport = (0, 0, size, size)
            self.fbo.clear(*self.background, 1.0)
            self._render(k, first, end)
            if self.edges is not None:
                self._overdraw_edges(k, positions, self.edges)
            if self.samples:
                ctx.copy_framebuffer(self.resolved, self.fbo)
            self.resolved.read_into(self.face_buffer, components=3)
            slot = k if slots is None else slots[k]
            out[:, slot * size : (slot + 1) * size] = self.face_buffer[::-1]
        return out

    def _overdraw_edges(self, k: int, positions: np.ndarray, table: EdgeTable) -> None:
        solid, blended, triangles = self._modes
        xyw = positions @ self._xyw[:3] + self._xyw[3]
        edges = overdraw_edges(table, self.triangles, xyw)
        self.last_edges[k] = len(edges)
        if not len(edges):
            return
        self.edge_index.write(edges)
        self.ctx.enable_only(blended)
        self.fbo.depth_mask = False
        self.edge_vaos[k].render(triangles, vertices=3 * len(edges))
        self.fbo.depth_mask = True

    def release(self) -> None:
        buffers = [b for pair in self.dynamic for b in pair]
        objs = [*self.vaos, *buffers, self.static, self.index, self.prog]
        if self.edges is not None:
            objs += [*self.edge_vaos, self.edge_index, self.edge_prog]
        if self.texture is not None:
            objs += [
                self.texture,
                self.uv_buffer,
                *self.flat_vaos,
                self.flat_static,
                self.flat_prog,
            ]
        for obj in objs:
            obj.release()
        for fbo in {id(self.fbo): self.fbo, id(self.resolved): self.resolved}.values():
            for attachment in (*fbo.color_attachments, fbo.depth_attachment):
                if attachment is not None:
                    attachment.release()
            fbo.release()
