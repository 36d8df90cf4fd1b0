"""Headless OpenGL drawing of posed faces with moderngl (EGL; Mesa llvmpipe or a GPU).

One :class:`FaceCanvas` draws one or more faces side by side and returns one frame: fixed
perspective camera framed on the face's own feature points, two lights with Blinn-Phong shading
computed in linear light, neutral grey background and multisample anti-aliasing (resolved before
read-back). Vertices arrive posed in world space (:meth:`renderer.deform.Rig.posed`), so nothing
but vertex data changes between draws: on Mesa's llvmpipe a uniform change between the faces of
a frame costs more than drawing them. Each face is drawn alone into one square target, so its
pixels do not depend on its side (A|B and B|A are exact mirrors of each other).
"""

from __future__ import annotations

import threading

import numpy as np

from app.errors import InputError
from renderer.deform import FaceFrame, Rig

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
    vec3 n = in_norm;
    vec3 view = normalize(camera - in_pos);
    float nv = dot(n, view);
    if (nv < 0.0) { n = -n; nv = -nv; }
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

_CONTEXTS: dict[int, object] = {}


class GLUnavailable(InputError):
    """No OpenGL context could be made; the message says what to install."""


def context():
    """The calling thread's headless moderngl context (created on first use)."""
    key = threading.get_ident()
    if key not in _CONTEXTS:
        try:
            import moderngl

            _CONTEXTS[key] = moderngl.create_standalone_context(backend="egl")
        except Exception as exc:  # the backends raise assorted types
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise GLUnavailable(
                "no OpenGL context could be made (headless EGL): install Mesa's EGL and "
                "software rasteriser (Debian: apt-get install libegl1 libgl1-mesa-dri) or a "
                f"GPU driver with EGL; the backend said: {reason}"
            ) from None
    return _CONTEXTS[key]


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
    vp = perspective(fov, 1.0, 8.0 * unit, 14.0 * unit) @ look_at(eye, target,
                                                                 np.array([0.0, 1.0, 0.0]))
    return vp, eye


def project(vp: np.ndarray, points: np.ndarray, size: int) -> np.ndarray:
    """Pixel coordinates (x right, y down) of world ``points`` in a ``size`` square view."""
    h = np.column_stack([points, np.ones(len(points))]) @ vp.T
    ndc = h[:, :2] / h[:, 3:4]
    return np.column_stack([(ndc[:, 0] + 1) * size / 2, (1 - ndc[:, 1]) * size / 2])


class FaceCanvas:
    """Draws ``n_faces`` copies of one rigged face side by side and reads the frame back.

    ``samples``: multisample anti-aliasing (0 or 1 turns it off).
    """

    def __init__(self, rig: Rig, size: int, n_faces: int = 1, samples: int = 4,
                 background: tuple[float, float, float] = (0.55, 0.56, 0.58)) -> None:
        import moderngl

        self.ctx = ctx = context()
        self.rig, self.size, self.n_faces = rig, size, n_faces
        self.background = background
        self.vp, self.camera = camera_for(rig)
        face = rig.face
        self.prog = ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT)
        self.prog["mvp"].write(self.vp.T.astype("f4").tobytes())
        self.prog["camera"].value = tuple(self.camera)
        self.static = ctx.buffer(face.colors.astype("f4").tobytes())
        self.index = ctx.buffer(face.triangles.astype("i4").tobytes())
        self.dynamic = [(ctx.buffer(reserve=face.n_vertices * 3 * 4),
                         ctx.buffer(reserve=face.n_vertices * 3 * 4)) for _ in range(n_faces)]
        self.vaos = [ctx.vertex_array(self.prog, [(pos, "3f", "in_pos"), (nrm, "3f", "in_norm"),
                                                  (self.static, "4f", "in_color")],
                                      index_buffer=self.index)
                     for pos, nrm in self.dynamic]
        self.samples = samples if samples > 1 else 0
        self.fbo = ctx.framebuffer(ctx.renderbuffer((size, size), 3, samples=self.samples),
                                   ctx.depth_renderbuffer((size, size), samples=self.samples))
        self.resolved = (ctx.framebuffer(ctx.renderbuffer((size, size), 3)) if self.samples
                         else self.fbo)
        self.face_buffer = np.empty((size, size, 3), np.uint8)
        self.buffer = np.empty((size, size * n_faces, 3), np.uint8)
        self._modes = moderngl.DEPTH_TEST | moderngl.CULL_FACE, moderngl.TRIANGLES

    def draw(self, frames: list[FaceFrame]) -> np.ndarray:
        """Draw one frame per face (left to right); returns the (H, W, 3) uint8 frame, top row
        first (a buffer reused by the next draw)."""
        ctx, size = self.ctx, self.size
        flags, triangles = self._modes
        for k, frame in enumerate(frames):
            positions, normals = self.rig.posed(frame)
            self.dynamic[k][0].write(positions)
            self.dynamic[k][1].write(normals)
            self.fbo.use()
            ctx.enable(flags)
            ctx.viewport = (0, 0, size, size)
            self.fbo.clear(*self.background, 1.0)
            self.vaos[k].render(triangles)
            if self.samples:
                ctx.copy_framebuffer(self.resolved, self.fbo)
            self.resolved.read_into(self.face_buffer, components=3)
            self.buffer[:, k * size:(k + 1) * size] = self.face_buffer[::-1]
        return self.buffer

    def release(self) -> None:
        buffers = [b for pair in self.dynamic for b in pair]
        for obj in (*self.vaos, *buffers, self.static, self.index, self.prog):
            obj.release()
        for fbo in {id(self.fbo): self.fbo, id(self.resolved): self.resolved}.values():
            for attachment in (*fbo.color_attachments, fbo.depth_attachment):
                if attachment is not None:
                    attachment.release()
            fbo.release()
