"""Headless OpenGL drawing of posed faces with moderngl (EGL; Mesa llvmpipe or a GPU).

One :class:`FaceCanvas` draws one or more faces side by side and returns one frame: fixed
perspective camera framed on the face's own feature points, two lights with Blinn-Phong shading
computed per vertex in linear light, neutral grey background, and anti-aliasing by discontinuity
edge overdraw (:mod:`renderer.edges`; the default) or by multisampling. Vertices arrive posed in
world space (:meth:`renderer.deform.Rig.posed`), so nothing but vertex data changes between
draws: on Mesa's llvmpipe a uniform change between the faces of a frame costs more than drawing
them. Each face is drawn alone into one square target, so its pixels do not depend on its side
(A|B and B|A are exact mirrors of each other).
"""

from __future__ import annotations

import threading

import numpy as np

from app.errors import InputError
from renderer import defaults
from renderer.deform import FaceFrame, Rig
from renderer.edges import EdgeTable, edge_table, overdraw_edges
from renderer.egldevice import device_index

_VERTEX = """
#version 330
uniform mat4 mvp;
uniform vec3 camera;
in vec3 in_pos;
in vec3 in_norm;
in vec4 in_color;
out vec3 v_color;
const vec3 KEY = normalize(vec3(-0.45, 0.55, 0.85));
const vec3 FILL = normalize(vec3(0.6, 0.05, 0.6));
void main() {
    // Blinn-Phong per vertex (the mesh is finer than 4 px where it shows), in approximately
    // (gamma 2) linear light; powers by squaring are cheap on software rasterisers
    // a vertex on a silhouette may face slightly away: it keeps its normal (back faces are
    // culled, so nothing is lit from behind), with the rim term at its grazing maximum
    vec3 n = in_norm;
    vec3 view = normalize(camera - in_pos);
    float nv = max(dot(n, view), 0.0);
    vec3 albedo = in_color.rgb * in_color.rgb;
    float key = max(dot(n, KEY), 0.0);
    float fill = max(dot(n, FILL), 0.0);
    float r = 1.0 - nv;
    float s = max(dot(n, normalize(KEY + view)), 0.0);
    s *= s; s *= s; s *= s; s *= s; s *= s;
    vec3 light = albedo * (0.16 + 0.95 * key + 0.35 * fill) + 0.10 * r * r * r
                 + 0.35 * s * in_color.a;
    v_color = sqrt(clamp(light, 0.0, 1.0));
    gl_Position = mvp * vec4(in_pos, 1.0);
}
"""

_FRAGMENT = """
#version 330
in vec3 v_color;
out vec4 f_color;
void main() {
    f_color = vec4(v_color, 1.0);
}
"""

#: The textured head's lighting (:mod:`renderer.skintexture`), still per vertex: a warm key
#: from above on the face's right, a cooler fill from its left at half the key, sky-over-
#: ground ambient and a faint rim, with the diffuse terms wrapped past the terminator as light
#: scattered in skin is. The albedo comes per pixel from the texture: in (gamma 2) linear light
#: a pixel is (c t)^2 D + S for vertex colour c, texel t, diffuse light D and specular S, so
#: its display value c t sqrt(D) is exact without the specular, which is added as the
#: difference it makes at a typical texel (TEXEL) - one fetch and one multiply-add a pixel.
_VERTEX_TEXTURED = """
#version 330
uniform mat4 mvp;
uniform vec3 camera;
in vec3 in_pos;
in vec3 in_norm;
in vec4 in_color;
in vec2 in_uv;
out vec3 v_light;
out vec3 v_spec;
out vec2 v_uv;
const vec3 KEY = normalize(vec3(-0.5, 0.5, 0.75));
const vec3 FILL = normalize(vec3(0.75, 0.1, 0.6));
const vec3 KEY_RGB = vec3(1.0, 0.95, 0.88);
const vec3 FILL_RGB = vec3(0.78, 0.84, 0.95);
const float TEXEL = 0.72;
void main() {
    vec3 n = in_norm;
    vec3 view = normalize(camera - in_pos);
    float nv = max(dot(n, view), 0.0);
    float key = max((dot(n, KEY) + 0.3) / 1.3, 0.0);
    float fill = max((dot(n, FILL) + 0.4) / 1.4, 0.0);
    float sky = 0.5 + 0.5 * n.y;
    vec3 diffuse = mix(vec3(0.10, 0.09, 0.09), vec3(0.17, 0.18, 0.20), sky)
                   + 0.95 * KEY_RGB * key * key + 0.55 * FILL_RGB * fill
                   + vec3(0.07, 0.015, 0.0) * key * (1.0 - key);
    float r = 1.0 - nv;
    float s = max(dot(n, normalize(KEY + view)), 0.0);
    s *= s; s *= s; s *= s; s *= s; s *= s;
    vec3 spec = 0.07 * r * r * r * FILL_RGB + 0.30 * s * in_color.a * KEY_RGB;
    vec3 d = sqrt(diffuse);
    vec3 typical = in_color.rgb * TEXEL;
    v_light = in_color.rgb * d;
    v_spec = sqrt(typical * typical * diffuse + spec) - typical * d;
    v_uv = in_uv;
    gl_Position = mvp * vec4(in_pos, 1.0);
}
"""

#: The textured head's triangles that show one texel (see :class:`FaceCanvas`): its colour is
#: in the vertex colour, so no fetch.
_FRAGMENT_FLAT = """
#version 330
in vec3 v_light;
in vec3 v_spec;
in vec2 v_uv;
out vec4 f_color;
void main() {
    f_color = vec4(v_light + v_spec, 1.0);
}
"""

_FRAGMENT_TEXTURED = """
#version 330
uniform sampler2D albedo;
in vec3 v_light;
in vec3 v_spec;
in vec2 v_uv;
out vec4 f_color;
void main() {
    vec4 texel = texture(albedo, v_uv);
    CUTOUT
    f_color = vec4(texel.rgb * v_light + v_spec, 1.0);
}
"""

#: A texel a cut-out material does not draw (alpha made 0 or 1 per material, with filtering
#: in between: :mod:`renderer.gltftexture`), dropped before it writes colour or depth.
_CUTOUT = "if (texel.a < 0.5) discard;"

#: Discontinuity edge overdraw (see :mod:`renderer.edges`): each input triangle is an edge
#: (a, b) plus the vertex opposite it in its front-facing triangle; out comes a strip reaching
#: one pixel footprint outside the edge and half a footprint inside, 0.5 px past each end.
#: The vertex shader's outputs (VARYINGS) pass through to the strip's ends.
_EDGE_GEOMETRY = """
#version 330
layout(triangles) in;
layout(triangle_strip, max_vertices = 4) out;
uniform vec2 half_size;
VARYINGS_IN
VARYINGS_OUT
noperspective out float g_dist;
void emit(vec4 clip, vec2 offset, float dist, int k) {
    gl_Position = vec4(clip.xy + offset / half_size * clip.w, clip.zw);
    VARYINGS_COPY
    g_dist = dist;
    EmitVertex();
}
void main() {
    vec4 a = gl_in[0].gl_Position, b = gl_in[1].gl_Position, o = gl_in[2].gl_Position;
    if (a.w <= 0.0 || b.w <= 0.0 || o.w <= 0.0) return;
    vec2 pa = a.xy / a.w * half_size, pb = b.xy / b.w * half_size;
    vec2 po = o.xy / o.w * half_size;
    vec2 along = pb - pa;
    float len = length(along);
    if (len < 1e-4) return;
    along /= len;
    vec2 outside = vec2(-along.y, along.x);
    if (dot(po - pa, outside) > 0.0) outside = -outside;
    // a pixel's footprint across the edge: 1 px for an axis-aligned edge, sqrt 2 at 45 degrees
    float k = abs(outside.x) + abs(outside.y);
    vec2 reach_out = k * outside, reach_in = -0.5 * k * outside, ext = 0.5 * along;
    emit(a, reach_out - ext, 1.0, 0);
    emit(a, reach_in - ext, -0.5, 0);
    emit(b, reach_out + ext, 1.0, 1);
    emit(b, reach_in + ext, -0.5, 1);
    EndPrimitive();
}
"""

#: Coverage of a box pixel by a one-pixel-wide line centred half a pixel outside the edge
#: (Sander et al.'s anti-aliased line): 1 - distance, in pixel footprints across the edge.
#: The surface grows by half a pixel; in exchange the ramp spans a whole pixel.
_EDGE_FRAGMENT = """
#version 330
UNIFORMS
VARYINGS_IN
noperspective in float g_dist;
out vec4 f_color;
void main() {
    CUTOUT
    f_color = vec4(COLOUR, clamp(1.0 - g_dist, 0.0, 1.0));
}
"""

#: Per look: the vertex shader's outputs (GLSL type, name after ``v_``), the edge fragment
#: shader's uniforms and its colour expression.
_PLAIN: tuple[tuple[tuple[str, str], ...], str, str] = ((("vec3", "color"),), "", "v_color")
_TEXTURED: tuple[tuple[tuple[str, str], ...], str, str] = (
    (("vec3", "light"), ("vec3", "spec"), ("vec2", "uv")),
    "uniform sampler2D albedo;",
    "texture(albedo, v_uv).rgb * v_light + v_spec",
)


def shaders(textured: bool, cutout: bool = False) -> dict[str, str]:
    """The GLSL of the face and of its edge overdraw, plain (per-vertex colour) or textured;
    ``cutout``: the texture's alpha says which texels are drawn (an avatar's masked cards)."""
    varyings, uniforms, colour = _TEXTURED if textured else _PLAIN
    names = [name for _, name in varyings]

    def declare(pattern: str) -> str:
        return "\n".join(pattern.format(type=t, name=n) for t, n in varyings)

    geometry = (
        _EDGE_GEOMETRY.replace("VARYINGS_IN", declare("in {type} v_{name}[];"))
        .replace("VARYINGS_OUT", declare("out {type} g_{name};"))
        .replace("VARYINGS_COPY", " ".join(f"g_{n} = v_{n}[k];" for n in names))
    )
    for n in names:
        colour = colour.replace(f"v_{n}", f"g_{n}")
    cut = "vec4 texel = texture(albedo, g_uv); " + _CUTOUT if textured and cutout else ""
    edge_fragment = (
        _EDGE_FRAGMENT.replace("UNIFORMS", uniforms)
        .replace("VARYINGS_IN", declare("in {type} g_{name};"))
        .replace("CUTOUT", cut)
        .replace("COLOUR", colour)
    )
    fragment = _FRAGMENT_TEXTURED.replace("CUTOUT", _CUTOUT if cutout else "")
    return {
        "vertex": _VERTEX_TEXTURED if textured else _VERTEX,
        "fragment": fragment if textured else _FRAGMENT,
        "flat_fragment": _FRAGMENT_FLAT,
        "edge_geometry": geometry,
        "edge_fragment": edge_fragment,
    }


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


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    f = target - eye
    f = f / np.linalg.norm(f)
    s = np.cross(f, up)
    s = s / np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def perspective(fov_y: float, aspect: float, near: float, far: float) -> np.ndarray:
    f = 1.0 / np.tan(fov_y / 2.0)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = f / aspect, f
    m[2, 2], m[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def camera_for(rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    """Fixed camera framed on the face: (view-projection matrix, camera position).

    Frames head and neck from the feature points: the unit is the eye-to-mouth height L, the
    view spans 4.4 L vertically, centred 0.4 L below the eyes, from 10.5 L in front.
    """
    fp = rig.face.feature_points
    eyes = (fp["3.5"] + fp["3.6"]) / 2.0
    mouth = (fp["2.2"] + fp["2.3"]) / 2.0
    unit = float(eyes[1] - mouth[1])
    target = np.array([eyes[0], eyes[1] - 0.42 * unit, eyes[2] - unit])
    eye = target + np.array([0.0, 0.03 * unit, 10.5 * unit])
    fov = 2.0 * np.arctan(2.2 / 10.5)
    vp = perspective(fov, 1.0, 8.0 * unit, 14.0 * unit) @ look_at(
        eye, target, np.array([0.0, 1.0, 0.0])
    )
    return vp, eye


def project(vp: np.ndarray, points: np.ndarray, size: int) -> np.ndarray:
    """Pixel coordinates (x right, y down) of world ``points`` in a ``size`` square view."""
    h = np.column_stack([points, np.ones(len(points))]) @ vp.T
    ndc = h[:, :2] / h[:, 3:4]
    return np.column_stack([(ndc[:, 0] + 1) * size / 2, (1 - ndc[:, 1]) * size / 2])


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
        # a textured face's triangles whose corners share one UV (eyes, teeth, neck, clothes
        # on the built-in head: half its pixels) show one texel: drawn without the texture
        # fetch, which is most of what the texture costs on llvmpipe. Order: flat, textured,
        # so a pass is at most two draws
        flat = np.zeros(face.n_triangles, bool)
        triangles = face.triangles
        if face.textured:
            uv = np.asarray(face.uvs)[face.triangles]
            flat = (uv == uv[:, :1]).all(axis=(1, 2))
            if cutout:  # a flat triangle on a cut-out texel is not drawn at all
                drawn = ~flat | (flat_colors(face, alpha=True)[triangles[:, 0]] >= 0.5)
                triangles, flat = triangles[drawn], flat[drawn]
        # the inside of the mouth (cavity, teeth, tongue) at both ends, so a face whose lips
        # are closed, where none of it can show, is drawn without it (draw)
        inside = np.zeros(face.n_vertices, bool)
        inside[face.groups.get("mouth_interior", [])] = True
        interior = inside[triangles].all(axis=1)
        order = [flat & interior, flat & ~interior, ~flat & ~interior, ~flat & interior]
        self.index = ctx.buffer(
            np.concatenate([triangles[m] for m in order]).astype("i4").tobytes()
        )
        ends = np.cumsum([int(m.sum()) for m in order])
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
            self.flat_static = ctx.buffer(flat_colors(face).astype("f4").tobytes())
            self.flat_prog = ctx.program(
                vertex_shader=glsl["vertex"], fragment_shader=glsl["flat_fragment"]
            )
            programs.append(self.flat_prog)
            self.flat_vaos = [
                self._vertex_array(self.flat_prog, pos, nrm, self.index, colors=self.flat_static)
                for pos, nrm in self.dynamic
            ]
            self.runs = [
                [(0, ends[1], fv), (ends[1], ends[3], v)]
                for v, fv in zip(self.vaos, self.flat_vaos, strict=True)
            ]
        self.edges = None
        if antialias == "edges":
            hidden = np.zeros(face.n_vertices, bool)
            hidden[face.groups.get("hidden_outline", [])] = True
            self.edges = edge_table(triangles, hidden)
            self.triangles = np.asfortranarray(triangles, dtype=np.intp)
            self.edge_prog = ctx.program(
                vertex_shader=glsl["vertex"],
                geometry_shader=glsl["edge_geometry"],
                fragment_shader=glsl["edge_fragment"],
            )
            self.edge_prog["half_size"].value = (size / 2.0, size / 2.0)
            programs.append(self.edge_prog)
            self.edge_index = ctx.buffer(reserve=max(len(self.edges.a), 1) * 3 * 4)
            self.edge_vaos = [
                self._vertex_array(self.edge_prog, pos, nrm, self.edge_index)
                for pos, nrm in self.dynamic
            ]
            # clip-space x, y, w of world points: rows 0, 1 and 3 of the view-projection
            self._xyw = self.vp[[0, 1, 3]].T.astype(np.float32)
        for prog in programs:
            prog["mvp"].write(self.vp.T.astype("f4").tobytes())
            prog["camera"].value = tuple(self.camera)
        self.samples = samples if antialias == "msaa" and samples > 1 else 0
        self.fbo = ctx.framebuffer(
            ctx.renderbuffer((size, size), 3, samples=self.samples),
            ctx.depth_renderbuffer((size, size), samples=self.samples),
        )
        self.resolved = (
            ctx.framebuffer(ctx.renderbuffer((size, size), 3)) if self.samples else self.fbo
        )
        self.face_buffer = np.empty((size, size, 3), np.uint8)
        self.background_u8 = np.round(np.asarray(background) * 255).astype(np.uint8)
        self.buffer = np.empty((size, size * n_faces, 3), np.uint8)
        self._modes = (
            moderngl.DEPTH_TEST | moderngl.CULL_FACE,
            moderngl.DEPTH_TEST | moderngl.BLEND,
            moderngl.TRIANGLES,
        )
        self.last_edges = [0] * n_faces  # edges overdrawn per face in the last draw

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
