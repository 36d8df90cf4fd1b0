"""The GLSL the face is drawn with: per-vertex lighting, plain or textured, and the edge overdraw.

Two looks. Plain: Blinn-Phong per vertex from two lights in (gamma 2) linear light, the
colour per vertex. Textured (the built-in head's skin, an avatar's atlas): a warm key, a cooler
fill, sky-over-ground ambient and a faint rim, still lit per vertex, the albedo fetched per
pixel. Each look has the fragment shader of its faces and the geometry and fragment shaders of
its discontinuity edge overdraw (:mod:`renderer.edges`), which carry the vertex shader's
outputs through to a one-pixel strip outside each silhouette edge. :func:`shaders` assembles
the set for a look; :mod:`renderer.gl` compiles and draws them.
"""

from __future__ import annotations

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
