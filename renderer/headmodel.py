"""The built-in parametric head: mesh, colours, MPEG-4 feature points and FAPU by construction.

In the spirit of Parke's parameterised face (thesis sec. 2.1.2): a polygon mesh whose shape
comes from a few named parameters (head, jaw, nose, lips, eye sockets as smooth unions in
:mod:`renderer.sdf`), with the upper and lower lip left unconnected so that opening the jaw
parts them. The skin is sampled on a ray grid about a point inside the head, dense on the face
and sparse at the back, so the whole head stays near 11k triangles (the cost of a frame on a
software rasteriser grows with the count). Eyeballs (iris, pupil),
eyelids, mouth cavity with teeth, ears, neck and shoulders are separate parts.

Model units are millimetres; axes as in Xface (+x the face's left, +y up, +z forward).

Example
-------
>>> face = builtin_face()
>>> 8_000 < face.n_triangles < 14_000
True
>>> sorted(face.fapu) == ['ENS0', 'ES0', 'IRISD0', 'MNS0', 'MW0']
True
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

import renderer.headparts as hp
from renderer.face import OPTIONAL_GROUPS, REQUIRED_GROUPS, Face, fapu_from_feature_points
from renderer.mouthparts import mouth_parts, oral_cavity
from renderer.neckear import ear, neck_and_shoulders
from renderer.part import merge
from renderer.sdf import capsule, ellipsoid, ray_surface, smax, smin
from renderer.skinpaint import hair_mask
from renderer.skintexture import cached_skin_texture, white_uv

#: Ray origin inside the head: the skin is star-shaped about it.
CENTRE = np.array([0.0, -5.0, 12.0])
MOUTH_Y = -58.0  # stomion (lips meet), in the midline
MOUTH_HALF_WIDTH = 25.0  # x of the lip corners
EYE_X, EYE_Y, EYE_Z = 31.0, 14.0, 70.0  # eyeball centre (left eye at +x)
EYE_RADIUS = 12.0
COVER_RADIUS = EYE_RADIUS + 0.45  # the skin over the eyeball, under the lids (radius + 0.8, 1)
PIVOT_71 = (0.0, -40.0, -18.0)  # top of the spine: head rotation pivot
JAW_HINGE = (0.0, -4.0, 10.0)  # temporo-mandibular joint axis (parallel to x)
EAR_POSITION = np.array([66.0, 2.0, -4.0])  # where the left ear meets the head
N_AZIMUTH, N_ELEVATION = 64, 52


def _skin_sdf(p: np.ndarray) -> np.ndarray:
    """Signed distance of the skin surface (head, face, nose, lips) in millimetres."""
    x = np.abs(p[:, 0])[:, None]
    q = np.concatenate([x, p[:, 1:]], axis=1)  # mirror: model the left half only
    d = ellipsoid(q, (0, 28, -6), (74, 100, 98))  # cranium
    d = smin(d, ellipsoid(q, (0, -28, 24), (64, 70, 70)), 28)  # mid face
    d = smin(d, ellipsoid(q, (0, -70, 40), (53, 36, 50)), 22)  # mandible
    d = smin(d, ellipsoid(q, (0, -95, 72), (21, 14, 18)), 14)  # chin
    d = smin(d, ellipsoid(q, (46, 2, 50), (18, 13, 22)), 14)  # cheekbone
    d = smin(d, ellipsoid(q, (30, -32, 62), (22, 22, 24)), 18)  # cheek
    d = smin(d, ellipsoid(q, (0, 50, 30), (60, 46, 60)), 22)  # forehead
    d = smin(d, ellipsoid(q, (26, 27, 76), (20, 7, 9)), 8)  # brow ridge
    d = smax(d, -ellipsoid(q, (EYE_X, EYE_Y, 84), (17, 11, 12)), 6)  # eye socket
    d = smin(d, _lid_cover(q), 2.5)
    d = smin(d, ellipsoid(q, (0, -58, 80), (32, 24, 18)), 10)  # muzzle
    nose = capsule(q, (0, 20, 84), (0, -22, 104), 6.5, 8.5)
    nose = smin(nose, ellipsoid(q, (0, -25, 105), (10, 9.5, 9.5)), 5)  # tip
    nose = smin(nose, ellipsoid(q, (13, -31, 93), (8, 7, 8)), 5)  # ala
    d = smin(d, nose, 6)
    d = smin(d, ellipsoid(q, (0, -52.5, 93.5), (24, 6.5, 10)), 4)  # upper lip
    d = smin(d, ellipsoid(q, (0, -64.5, 91.5), (21, 7.5, 10)), 4)  # lower lip
    # hair volume on the skull
    return d - 5.0 * hair_mask(p)


def _lid_cover(q: np.ndarray) -> np.ndarray:
    """The skin over the eyeball outside the eye opening: a ball between eyeball and lids.

    It fills the socket where the lids root (and beyond the eye corners), so the lids meet
    skin that follows the eyeball instead of a socket rim, and closed lids read as skin over
    a ball rather than a cap set into a hole. Outside the opening by 3 degrees (under the lid
    margins at rest); approximate distance, as for the other primitives.
    """
    e = q - np.array([EYE_X, EYE_Y, EYE_Z])
    ball = np.linalg.norm(e, axis=1) - COVER_RADIUS
    az = np.degrees(np.arctan2(e[:, 0], e[:, 2]))
    el = np.degrees(np.arctan2(e[:, 1], np.hypot(e[:, 0], e[:, 2])))
    lateral = az / hp.LID_HALF_WIDTH
    opening = np.minimum.reduce(
        [
            hp.lid_margin(lateral, upper=True) - 3.0 - el,
            el - hp.lid_margin(lateral, upper=False) - 3.0,
            hp.LID_HALF_WIDTH + 3.0 - np.abs(az),
        ]
    )
    # degrees inside the opening -> millimetres on the ball
    return np.maximum(ball, np.radians(opening) * COVER_RADIUS)


#: Looks of the built-in head: ``textured`` (skin texture, strand brows, eyelashes; the
#: default) and ``plain`` (per-vertex colour only, the head before the texture).
LOOKS: tuple[str, ...] = ("textured", "plain")


def check_look(look: str) -> None:
    """An InputError naming the ``look`` field unless ``look`` is one of :data:`LOOKS`."""
    if look not in LOOKS:
        from app.errors import InputError

        raise InputError(f"must be one of {', '.join(LOOKS)}, got {look!r}", field="look")


@lru_cache(maxsize=2)
def builtin_face(look: str = "textured") -> Face:
    """Build (once per process and look) the built-in head as a :class:`Face`.

    ``look``: ``"textured"`` adds the skin texture (:mod:`renderer.skintexture`) and the
    eyelashes; ``"plain"`` is the same mesh without lashes, coloured per vertex.
    """
    check_look(look)
    textured = look == "textured"
    parts = [
        hp.skin_grid(
            _skin_sdf,
            CENTRE,
            ray_surface,
            N_AZIMUTH,
            N_ELEVATION,
            MOUTH_Y,
            MOUTH_HALF_WIDTH,
            textured=textured,
        )
    ]
    for side, sx in (("l", 1.0), ("r", -1.0)):
        centre = np.array([sx * EYE_X, EYE_Y, EYE_Z])
        parts.append(hp.eyeball(centre, EYE_RADIUS, f"eyeball_{side}"))
        for upper, radius in ((True, EYE_RADIUS + 1.0), (False, EYE_RADIUS + 0.8)):
            parts.append(
                hp.eyelid(
                    centre, radius, EYE_RADIUS + 0.25, upper=upper, side=side, lashes=textured
                )
            )
        parts.append(ear(np.array([sx, 1.0, 1.0]) * EAR_POSITION, sx, textured=textured))
    skin = parts[0]
    loop = skin.groups["mouth_loop"]
    parts.append(
        oral_cavity(
            skin.vertices[loop],
            skin.layers["lower_lip"][loop] > 0.5,
            skin.layers["jaw"][loop],
            MOUTH_Y,
        )
    )
    parts.append(mouth_parts(MOUTH_Y))
    parts.append(neck_and_shoulders())
    texture = None
    if textured:
        grid = parts[0].vertices[: N_ELEVATION * N_AZIMUTH].reshape(N_ELEVATION, N_AZIMUTH, 3)
        texture = cached_skin_texture(grid, MOUTH_Y, MOUTH_HALF_WIDTH)
    mesh = merge(parts, white_uv(N_ELEVATION) if textured else None)

    fp_vertices = {k[3:]: int(v[0]) for k, v in mesh.groups.items() if k.startswith("fp:")}
    feature_points = {k: mesh.vertices[i].astype(np.float64) for k, i in fp_vertices.items()}
    feature_points["7.1"] = np.array(PIVOT_71)
    return Face(
        vertices=mesh.vertices.astype(np.float32),
        triangles=mesh.triangles.astype(np.int32),
        colors=mesh.colors.astype(np.float32),
        feature_points=feature_points,
        fp_vertices=fp_vertices,
        fapu=fapu_from_feature_points(feature_points),
        groups={k: v for k, v in mesh.groups.items() if k in REQUIRED_GROUPS + OPTIONAL_GROUPS},
        weights={k: v.astype(np.float32) for k, v in mesh.layers.items()},
        jaw_pivot=np.array(JAW_HINGE),
        name="builtin" if textured else "builtin-plain",
        uvs=mesh.uvs,
        texture=texture,
    )
