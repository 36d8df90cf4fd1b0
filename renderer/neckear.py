"""The built-in head's neck, shoulders and ears.

The neck is a tube of elliptic rings from the shoulders to inside the skull, narrowest at
the middle and flaring into the trapezius at its base; its top ring is slanted (under the
jaw at the front, high behind the skull) so that nothing of it lies inside the mouth (a
straight cylinder reached up into the mouth, and the open mouth showed it as a flat plate).
Its ``head`` weight rises from 0 at the base to 1 under the jaw, and the head's turn bends it
(:meth:`renderer.deform.Rig.posed` turns each ring by its weight's share of the head's
rotation), so a rolled or nodding head carries its neck instead of turning on top of a
vertical post. Per-vertex colour darkens under the jaw and at the sides (the chin's shadow),
as the neck is lit per vertex like the rest.

Each ear is a shaped shell rather than a flattened ellipsoid: an outline of helix and lobe, a
rolled rim, the bowl of the concha and the antihelix between them, thin at the edge, turned
out from the head. With the textured look it samples the skin texture at the temple (a patch
of plain skin, :data:`EAR_PATCH`), so it carries the skin's pores and mottling instead of a
flat tone.

Model units are millimetres; axes as in :mod:`renderer.headmodel`.
"""

from __future__ import annotations

import numpy as np

from renderer.headparts import ellipsoid_mesh
from renderer.part import Part, merge
from renderer.sdf import smoothstep
from renderer.skinpaint import SKIN

NECK_BASE_Y = -215.0
NECK_RINGS, NECK_SEGMENTS = 10, 28


def neck_and_shoulders() -> Part:
    """Neck (bending with the head by its ``head`` weight) and shoulders (still)."""
    t = np.linspace(0.0, 1.0, NECK_RINGS)
    ang = np.linspace(0, 2 * np.pi, NECK_SEGMENTS, endpoint=False)
    T, A = np.meshgrid(t, ang, indexing="ij")
    top = -69.0 - 29.0 * np.cos(A)  # under the jaw in front, high at the back
    y = NECK_BASE_Y + T * (top - NECK_BASE_Y)
    # half width and depth: flared into the shoulders at the base, narrowest at mid height
    flare = np.exp(-T / 0.12)
    half_w = 45.0 + 20.0 * flare - 2.5 * np.sin(np.pi * T)
    half_d = 42.0 + 10.0 * flare - 2.0 * np.sin(np.pi * T)
    centre_z = -10.0 + 8.0 * T
    v = np.stack([half_w * np.sin(A), y, centre_z + half_d * np.cos(A)], -1).reshape(-1, 3)
    rows, cols = np.meshgrid(np.arange(NECK_RINGS - 1), np.arange(NECK_SEGMENTS), indexing="ij")
    a = rows * NECK_SEGMENTS + cols
    b = rows * NECK_SEGMENTS + (cols + 1) % NECK_SEGMENTS
    tris = np.concatenate(
        [
            np.stack([a, b, b + NECK_SEGMENTS], -1).reshape(-1, 3),
            np.stack([a, b + NECK_SEGMENTS, a + NECK_SEGMENTS], -1).reshape(-1, 3),
        ]
    )
    front = np.cos(A).ravel()
    # the chin's shadow under the jaw, deeper in front; a little darker towards the back
    under = np.exp(-(((y.ravel() - top.ravel()) / 28.0) ** 2)) * smoothstep(-0.3, 0.8, front)
    tone = (1.0 - 0.30 * under) * (0.93 + 0.07 * front)
    colour = np.column_stack([(SKIN * 0.92)[None, :] * tone[:, None], np.full(len(v), 0.12)])
    neck = Part(v, tris, colour, layers={"head": smoothstep(0.08, 0.9, T.ravel())})
    torso = ellipsoid_mesh((0, -224, -10), (190, 70, 95), (0.27, 0.31, 0.40, 0.05), 10, 24)
    torso.layers["head"] = np.zeros(len(torso.vertices))
    return merge([neck, torso])


#: The skin texture's plain patch the ears sample (u0, v0, u1, v1): the temple and cheekbone
#: beside the eye, below the hairline and behind the brow's end (see the texture's layout in
#: :mod:`renderer.skintexture`; the right ear takes the mirror patch).
EAR_PATCH = (0.765, 0.32, 0.80, 0.52)

EAR_HEIGHT, EAR_WIDTH = 60.0, 32.0


def ear(pos: np.ndarray, sx: float, *, textured: bool = False) -> Part:
    """One ear at ``pos`` (where it meets the head) on side ``sx`` (+1 the face's left).

    A polar grid over the ear's outline (rings from the centre of the concha out to the
    rim); each ring point stands out from the head by a relief: the concha's bowl at the
    middle, the antihelix ridge around it, the helix rolled over at the rim, and the
    lobe below. Faces outwards and backwards as an ear stands off the skull.
    """
    n_rings, n_seg = 8, 18
    r = np.linspace(0.0, 1.0, n_rings)
    a = np.linspace(0.0, 2 * np.pi, n_seg, endpoint=False)
    R, A = np.meshgrid(r, a, indexing="ij")
    # outline: taller than wide, wider at the top (helix) than at the lobe
    width = 0.5 * EAR_WIDTH * (1.0 - 0.25 * smoothstep(0.0, -1.0, np.sin(A)))
    u = R * width * np.cos(A)  # backwards along the head
    w = R * 0.5 * EAR_HEIGHT * np.sin(A)  # up
    lobe = smoothstep(-0.4, -1.0, np.sin(A))
    relief = (
        -4.0 * np.exp(-((R / 0.45) ** 2))  # the concha's bowl
        + 2.2 * np.exp(-(((R - 0.62) / 0.12) ** 2)) * (1 - lobe)  # the antihelix
        + 3.4 * np.exp(-(((R - 0.92) / 0.09) ** 2)) * (1 - 0.6 * lobe)  # the helix's roll
        - 2.5 * smoothstep(0.95, 1.0, R)  # its edge turns in
    )
    stand = 7.0 + 9.0 * R * (0.5 + 0.5 * np.cos(A))  # the back edge stands further off
    local = np.stack([u, w, stand + relief], -1).reshape(-1, 3)
    # into head space: x out from the head, y up, z forward; the ear's back edge points back
    verts = np.column_stack([sx * local[:, 2], local[:, 1], -local[:, 0]])
    ang = np.radians(-12.0 * sx)  # turned a little forward
    rot = np.array([[np.cos(ang), 0, np.sin(ang)], [0, 1, 0], [-np.sin(ang), 0, np.cos(ang)]])
    verts = verts @ rot.T + pos
    idx = np.arange(n_rings * n_seg).reshape(n_rings, n_seg)
    c = np.arange(n_seg)
    p, q = idx[:-1][:, c], idx[:-1][:, (c + 1) % n_seg]
    s, t = idx[1:][:, c], idx[1:][:, (c + 1) % n_seg]
    tris = np.concatenate(
        [np.stack([p, q, t], -1).reshape(-1, 3), np.stack([p, t, s], -1).reshape(-1, 3)]
    )
    # the back of the shell, towards the head, is never seen; the front faces outwards
    e = verts[tris]
    normal = np.cross(e[:, 1] - e[:, 0], e[:, 2] - e[:, 0])
    inwards = normal[:, 0] * sx < 0
    tris[inwards] = tris[inwards][:, ::-1]
    # the bowl and the fold under the helix in shade, the rim and lobe a little redder
    depth = np.clip(-relief.ravel() / 4.0, 0.0, 1.0)
    rim = np.exp(-(((R.ravel() - 0.92) / 0.1) ** 2)) + lobe.ravel()
    tone = 1.0 - 0.35 * depth
    base = np.ones(3) if textured else SKIN * 0.95
    colour = base[None, :] * tone[:, None] * (1.0 + 0.06 * rim[:, None] * np.array([1, -0.5, -0.5]))
    part = Part(verts, tris, np.column_stack([colour, np.full(len(verts), 0.15)]))
    if textured:
        u0, v0, u1, v1 = EAR_PATCH
        if sx < 0:
            u0, u1 = 1.0 - u1, 1.0 - u0
        uu = (u.ravel() / EAR_WIDTH + 0.5) * (u1 - u0) + u0
        vv = (w.ravel() / EAR_HEIGHT + 0.5) * (v1 - v0) + v0
        part.uvs = np.column_stack([uu, vv]).astype(np.float32)
    return part
