"""Parts of the built-in head: the skin ray grid, eyeballs, eyelids, eyelashes.

Each builder returns a :class:`renderer.part.Part`: vertices, triangles, RGB + specular
colours, vertex groups (``fp:<name>`` marks a feature-point vertex) and per-vertex weight
layers for the deformation (``head``, ``jaw``, ``upper_lip``, ``lower_lip``, ``eyelid_*``).
Parts are merged by :func:`renderer.part.merge`; the skin's lips, brows, cheeks and hair are
painted by :mod:`renderer.skinpaint`, or textured (:mod:`renderer.skintexture`, with its seams
split by :mod:`renderer.uvseam`). See :mod:`renderer.headmodel` for the numbers that place them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from renderer.part import Part
from renderer.sdf import smoothstep
from renderer.skinpaint import SKIN, paint_skin
from renderer.skintexture import grid_uvs, pole_uv
from renderer.uvseam import split_seams

#: Jaw weights below this are cut (the rest rescaled to stay continuous).
JAW_WEIGHT_FLOOR = 0.06


def _grid_triangles(
    rows: int, cols: int, wrap: bool, vertices: np.ndarray | None = None
) -> np.ndarray:
    """Two triangles per cell of a rows x cols vertex grid (row-major), optionally wrapping.

    With ``vertices``, each cell is split along its shorter diagonal. A fixed diagonal makes a
    mirror-symmetric surface shade differently on its two halves (per-vertex shading follows
    the diagonal, so a ridge crossed by it shows as a crease above one eye only); the shorter
    diagonal is mirror-symmetric with the surface and follows its ridges.
    """
    r, c = np.meshgrid(np.arange(rows - 1), np.arange(cols if wrap else cols - 1), indexing="ij")
    a = r * cols + c
    b = r * cols + (c + 1) % cols
    one = np.concatenate(
        [
            np.stack([a, b, b + cols], -1).reshape(-1, 3),
            np.stack([a, b + cols, a + cols], -1).reshape(-1, 3),
        ]
    )
    if vertices is None:
        return one
    other = np.concatenate(
        [
            np.stack([a, b, a + cols], -1).reshape(-1, 3),
            np.stack([b, b + cols, a + cols], -1).reshape(-1, 3),
        ]
    )
    a, b = a.ravel(), b.ravel()
    flip = np.linalg.norm(vertices[b] - vertices[a + cols], axis=1) < np.linalg.norm(
        vertices[a] - vertices[b + cols], axis=1
    )
    return np.where(np.tile(flip, 2)[:, None], other, one)


def _warp(
    n: int,
    lo: float,
    hi: float,
    dense_lo: float,
    dense_hi: float,
    gain: float,
    endpoint: bool = True,
    bands: tuple[tuple[float, float, float], ...] = (),
) -> np.ndarray:
    """``n`` samples of [lo, hi] whose density is ``1 + gain`` inside [dense_lo, dense_hi],
    plus ``g`` more inside each ``(a, b, g)`` of ``bands``."""
    x = np.linspace(lo, hi, 4001)
    dens = 1.0 + gain * smoothstep(dense_lo - 8, dense_lo, x) * smoothstep(
        dense_hi + 8, dense_hi, x
    )
    for a, b, g in bands:
        dens = dens + g * smoothstep(a - 4, a, x) * smoothstep(b + 4, b, x)
    cdf = np.concatenate([[0.0], np.cumsum((dens[1:] + dens[:-1]) / 2 * np.diff(x))])
    u = np.linspace(0.0, cdf[-1], n + (0 if endpoint else 1))[:n]
    return np.interp(u, cdf, x)


def skin_grid(
    sdf: Callable[[np.ndarray], np.ndarray],
    centre: np.ndarray,
    solve,
    n_azimuth: int,
    n_elevation: int,
    mouth_y: float,
    half_width: float,
    textured: bool = False,
) -> Part:
    """The skin sampled on a ray grid about ``centre``, with the lips cut apart at the mouth.

    Rows are elevations (one row passes exactly through the mouth line), columns azimuths
    (column ``n_azimuth // 2`` is the midline); both are denser over the face. ``textured``:
    the colour comes from a texture (:mod:`renderer.skintexture`) at the grid's texture
    coordinates, the vertices keep a white colour (the inner lip edge a dark one).
    """
    az = np.radians(_warp(n_azimuth, -180, 180, -62, 62, 5.0, endpoint=False))
    az = az - az[n_azimuth // 2]  # exact midline column
    mouth_el = np.arctan2(mouth_y - centre[1], 97.0 - centre[2])
    for _ in range(4):  # the mouth row meets the midline exactly at mouth_y
        d = np.array([[0.0, np.sin(mouth_el), np.cos(mouth_el)]])
        hit = centre + solve(sdf, centre, d, 260.0)[:, None] * d
        mouth_el = np.arctan2(mouth_y - centre[1], hit[0, 2] - centre[2])
    mouth_el = np.degrees(mouth_el)
    # dense rows from the chin up over the hairline, whose edge (painted per vertex, like
    # the brows) otherwise fell between two rows 21 mm apart; the brows get twice as many
    el = _warp(n_elevation, -72, 86, -50, 50, 4.0, bands=((18.0, 34.0, 4.0),))
    m = int(np.argmin(np.abs(el - mouth_el)))
    el[m] = mouth_el
    el = np.radians(el)
    E, A = np.meshgrid(el, az, indexing="ij")
    dirs = np.stack([np.cos(E) * np.sin(A), np.sin(E), np.cos(E) * np.cos(A)], -1).reshape(-1, 3)
    t = solve(sdf, centre, dirs, 260.0)
    verts = centre + t[:, None] * dirs
    tris = _grid_triangles(n_elevation, n_azimuth, wrap=True, vertices=verts)
    # pole cap
    pole = len(verts)
    top = (n_elevation - 1) * n_azimuth + np.arange(n_azimuth)
    verts = np.vstack(
        [
            verts,
            centre
            + solve(sdf, centre, np.array([[0.0, 1.0, 0.0]]), 260.0) * np.array([0.0, 1.0, 0.0]),
        ]
    )
    tris = np.vstack([tris, np.column_stack([top, np.roll(top, -1), np.full(n_azimuth, pole)])])
    # the slit: duplicate the mouth-row vertices between the corners for the lower lip
    row_m = m * n_azimuth + np.arange(n_azimuth)
    slit = row_m[np.abs(verts[row_m, 0]) < half_width - 0.8]
    lower_copy = np.arange(len(verts), len(verts) + len(slit))
    remap = dict(zip(slit.tolist(), lower_copy.tolist(), strict=True))
    below = (tris // n_azimuth).min(axis=1) == m - 1  # cells between rows m-1 and m
    sub = tris[below]
    tris[below] = np.vectorize(lambda i: remap.get(int(i), int(i)))(sub)
    verts = np.vstack([verts, verts[slit]])
    n = len(verts)
    colors = paint_skin(verts, mouth_y, half_width)
    uvs = None
    if textured:
        uvs = np.vstack([grid_uvs(n_elevation, n_azimuth), [pole_uv(n_elevation)]])
        uvs = np.vstack([uvs, uvs[slit]]).astype(np.float32)
        colors[:, :3] = 1.0
        colors[np.concatenate([slit, lower_copy]), :3] = [0.5, 0.4, 0.4]  # x the lips' colour
    else:
        colors[np.concatenate([slit, lower_copy]), :3] = [0.32, 0.13, 0.13]

    # jaw weight: lower face follows the jaw; the cheeks beside the corners blend
    el_v = np.concatenate([E.ravel(), [np.pi / 2], np.full(len(slit), el[m])])
    az_v = np.concatenate([A.ravel(), [0.0], A.ravel()[slit]])
    side = smoothstep(half_width - 3, half_width + 10, np.abs(verts[:, 0]))
    tt = np.clip((el_v - el[m]) / np.radians(9.0), -1, 1)
    lateral = 0.5 * (1 - np.sin(np.pi / 2 * tt))
    span = (el_v < el[m]).astype(float)
    span[lower_copy] = 1.0
    # the skin under the chin stretches to the throat, which stays with the neck: an under-
    # jaw turning rigidly with the chin swung back into the neck as the jaw opened
    jaw = (
        ((1 - side) * span + side * lateral)
        * smoothstep(np.radians(100), np.radians(70), np.abs(az_v))
        * smoothstep(np.radians(-84.0), np.radians(-60.0), el_v)
    )
    # no tail of tiny weights: skin that would move by a hundredth of a millimetre stays, so
    # the region the jaw moves, which the mouth mosaic covers, ends below the cheekbones
    jaw = np.clip((jaw - JAW_WEIGHT_FLOOR) / (1.0 - JAW_WEIGHT_FLOOR), 0.0, 1.0)
    lower_lip = (el_v < el[m]).astype(float)
    lower_lip[lower_copy] = 1.0
    upper_lip = 1.0 - lower_lip

    front = np.flatnonzero((verts[:, 2] > 40) & (np.arange(n) < pole))
    front = front[~np.isin(front, lower_copy)]

    def near(target: tuple[float, float], among: np.ndarray) -> np.ndarray:
        d = np.hypot(verts[among, 0] - target[0], verts[among, 1] - target[1])
        return np.array([among[int(np.argmin(d))]])

    upper_row = slit
    fps: dict[str, np.ndarray] = {}
    hw2 = half_width * 0.5
    corner_cols = row_m[np.abs(verts[row_m, 0]) >= half_width - 0.8]
    for name, sx in (("l", 1.0), ("r", -1.0)):
        k = {"l": 0, "r": 1}[name]
        fps[f"2.{4 + k}"] = near((sx * half_width, mouth_y), corner_cols)
        fps[f"2.{6 + k}"] = near((sx * hw2, mouth_y), upper_row)
        fps[f"2.{8 + k}"] = near((sx * hw2, mouth_y), lower_copy)
        fps[f"8.{3 + k}"] = near((sx * (half_width + 3), mouth_y), corner_cols)
        up_y = mouth_y + 8.0 * (1 - 0.25) ** 0.35
        fps[f"8.{5 + k}"] = near((sx * hw2, up_y), front)
        fps[f"8.{7 + k}"] = near((sx * hw2, mouth_y - 8.8), front)
        brow_pts = ((14.0, 29.5), (31.0, 35.0), (48.0, 31.5))
        for j, (bx, by) in enumerate(brow_pts):
            fps[f"4.{1 + 2 * j + k}"] = near((sx * bx, by), front)
    fps["2.2"] = near((0.0, mouth_y), upper_row)
    fps["2.3"] = near((0.0, mouth_y), lower_copy)
    fps["8.1"] = near((0.0, mouth_y + 6.4), front)
    fps["8.2"] = near((0.0, mouth_y - 10.0), front)
    fps["2.10"] = near((0.0, -93.0), front)
    # the chin's lowest point in front (MPEG-4 2.1), not the skin under the jaw: the jaw
    # turns so that this point drops by FAP 3 x MNS0 / 1024, and a point under the jaw, near
    # the hinge's depth, had turned it twice as far
    chin = front[verts[front, 2] > 60.0]
    fps["2.1"] = chin[[int(np.argmin(np.abs(verts[chin, 0]) * 10.0 + verts[chin, 1]))]]
    fps["9.15"] = near((0.0, -37.0), front)
    fps["9.3"] = front[[int(np.argmax(verts[front, 2]))]]
    groups = {f"fp:{k}": v for k, v in fps.items()}
    # the lips' inner edge as a loop, for the cavity behind it (renderer.mouthparts): the
    # upper margin from corner to corner, then the lower margin back (the slit's columns
    # at the back of the head, where x is small too, are not the mouth)
    lips = verts[slit, 2] > 40.0
    upper_edge, lower_edge = slit[lips], lower_copy[lips]
    corners = [int(upper_edge[0]) - 1, int(upper_edge[-1]) + 1]
    groups["mouth_loop"] = np.concatenate(
        [[corners[0]], upper_edge, [corners[1]], lower_edge[::-1]]
    )
    layers = {"jaw": jaw, "lower_lip": lower_lip, "upper_lip": upper_lip}
    skin = Part(verts, tris, colors, groups, layers, uvs)
    if not textured:
        return skin
    columns = np.concatenate(
        [np.arange(n_elevation * n_azimuth) % n_azimuth, [-1], slit % n_azimuth]
    )
    return split_seams(skin, columns, n_azimuth, pole)


def _lathe(polar: np.ndarray, colours: np.ndarray, n_seg: int) -> tuple[np.ndarray, ...]:
    """Unit sphere rings about +z at the given polar angles (0 = +z pole), per-ring colours."""
    ang = np.linspace(0, 2 * np.pi, n_seg, endpoint=False)
    P, A = np.meshgrid(polar, ang, indexing="ij")
    v = np.stack([np.sin(P) * np.cos(A), np.sin(P) * np.sin(A), np.cos(P)], -1).reshape(-1, 3)
    c = np.repeat(colours, n_seg, axis=0)
    return v, _grid_triangles(len(polar), n_seg, wrap=True)[:, ::-1], c


def eyeball(centre: np.ndarray, radius: float, name: str) -> Part:
    """Eyeball with sclera, iris (with a darker limbus) and pupil; the pupil faces +z."""
    sclera, iris, limbus, pupil = (
        [0.93, 0.91, 0.87, 0.9],
        [0.36, 0.27, 0.18, 0.9],
        [0.14, 0.11, 0.09, 0.9],
        [0.03, 0.03, 0.03, 0.2],
    )
    spec = [
        (0.0, pupil),
        (0.10, pupil),
        (0.19, pupil),
        (0.19, iris),
        (0.33, iris),
        (0.44, limbus),
        (0.48, limbus),
        (0.48, sclera),
        (0.7, sclera),
        (1.0, sclera),
        (1.4, sclera),
        (1.9, sclera),
    ]  # the back, always inside the head, is left open
    polar = np.array([a for a, _ in spec])
    v, t, c = _lathe(polar, np.array([c for _, c in spec]), 20)
    verts = centre + radius * v
    idx = np.arange(len(verts))
    side = name[-1]
    return Part(
        verts, t, c, {name: idx, f"fp:3.{5 if side == 'l' else 6}": idx[[0]], "hidden_outline": idx}
    )


#: Half the angular width of the eye opening about the eyeball centre (degrees of azimuth).
LID_HALF_WIDTH = 78.0


def lid_margin(lateral: np.ndarray, *, upper: bool) -> np.ndarray:
    """Elevation (degrees about the eyeball centre) of a lid margin at rest.

    ``lateral`` is the azimuth over :data:`LID_HALF_WIDTH`, +1 at the outer corner: the upper
    lid arches 23 degrees above the eye's equator, the lower 18 below, both rising outwards.
    """
    a = np.clip(lateral, -1.0, 1.0)
    if upper:
        return 3 + 20 * (1 - a**2) + 3 * a
    return 1 - 19 * (1 - a**2) + 3 * a


def eyelid(
    centre: np.ndarray,
    radius: float,
    root_radius: float,
    *,
    upper: bool,
    side: str,
    lashes: bool = False,
) -> Part:
    """An eyelid shell over the eyeball: margin arc to a root that dives under the skin.

    The shell has ``radius`` at the margin and sinks to ``root_radius`` (between the eyeball
    and the skin over it) at the root, so it enters the skin's cover over the eyeball
    (:func:`renderer.headmodel._lid_cover`) at a grazing angle instead of standing on it as a
    separate cap, and still covers the eyeball wherever it turns.
    """
    alpha = np.radians(np.linspace(-LID_HALF_WIDTH, LID_HALF_WIDTH, 19))
    a_n = alpha / np.radians(LID_HALF_WIDTH)
    lateral = a_n * (1.0 if side == "l" else -1.0)  # +1 at the outer corner
    margin = np.radians(lid_margin(lateral, upper=upper))
    root = np.radians(np.full_like(alpha, 64.0 if upper else -58.0))
    s = np.linspace(0, 1, 9)  # rows fine enough to follow the skin over them when stretched
    B = margin[None, :] + s[:, None] * (root - margin)[None, :]
    A = np.broadcast_to(alpha, B.shape)
    v = np.stack([np.cos(B) * np.sin(A), np.sin(B), np.cos(B) * np.cos(A)], -1).reshape(-1, 3)
    sink = np.repeat((radius - root_radius) * s**2, len(alpha))[:, None]
    verts = centre + (radius - sink) * v
    tris = _grid_triangles(len(s), len(alpha), wrap=False)
    if not upper:  # rows run downwards: keep the outside counter-clockwise
        tris = tris[:, ::-1]
    col = np.tile(np.append(SKIN * 0.97, 0.2), (len(verts), 1))
    margin_col = [0.22, 0.15, 0.12] if upper else [0.62, 0.40, 0.38]
    col[: len(alpha), :3] = margin_col
    w = np.repeat(smoothstep(1.0, 0.45, s), len(alpha))
    name = f"eyelid_{'upper' if upper else 'lower'}_{side}"
    k = {"l": 0, "r": 1}[side]
    fp = f"fp:3.{(1 if upper else 3) + k}"
    hidden = np.arange(len(alpha), len(verts))  # all but the margin
    if lashes:
        lash_v, lash_t = eyelash_fringe(centre, radius, alpha, margin, upper=upper)
        hidden = np.concatenate([hidden, len(verts) + np.arange(len(lash_v) // 2)])
        tris = np.vstack([tris, lash_t + len(verts)])
        verts = np.vstack([verts, lash_v])
        lash = EYELASH if upper else 0.5 * EYELASH + 0.5 * np.append(margin_col, 0.05)
        col = np.vstack([col, np.tile(lash, (len(lash_v), 1))])
        w = np.concatenate([w, np.ones(len(lash_v))])  # the lashes ride on the margin
    groups = {
        name: np.arange(len(verts)),
        fp: np.array([len(alpha) // 2]),
        "hidden_outline": hidden,
    }
    return Part(verts, tris, col, groups, {name: w})


#: Eyelash colour (RGB + specular).
EYELASH = np.array([0.07, 0.05, 0.045, 0.05])


def eyelash_fringe(
    centre: np.ndarray, radius: float, alpha: np.ndarray, margin: np.ndarray, *, upper: bool
) -> tuple[np.ndarray, np.ndarray]:
    """A fringe of eyelashes on a lid margin: a strip whose free edge is a row of tufts.

    The lashes leave the margin outwards and curl away from the eye (up from the upper lid,
    down from the lower one): upper lashes 2.6 mm at the middle of the lid, shorter towards
    the corners, lower ones 0.9 mm. Lashes are a tenth of a pixel thick at 368 px, so what
    shows is the fringe they make together, clumped into tufts (two per margin segment above,
    one below); every free edge is a silhouette the edge overdraw draws again, which is what
    a fringe of single spikes cost (four times the edges). ``alpha`` and ``margin`` (radians)
    are the margin's azimuths and elevations about ``centre``, as in :func:`eyelid`. Roots
    sit 0.15 mm inside the margin so no gap shows (the first ``len(verts) // 2`` vertices:
    their edges lie under the margin); triangles face forwards (the camera) at rest.
    """
    n = (4 if upper else 2) * (len(alpha) - 1) + 1  # a tuft and a dip per step
    a = np.interp(np.linspace(0, len(alpha) - 1, n), np.arange(len(alpha)), alpha)
    b = np.interp(np.linspace(0, len(alpha) - 1, n), np.arange(len(alpha)), margin)
    radial = np.stack([np.cos(b) * np.sin(a), np.sin(b), np.cos(b) * np.cos(a)], -1)
    away = np.stack([-np.sin(b) * np.sin(a), np.cos(b), -np.sin(b) * np.cos(a)], -1)
    away = away if upper else -away
    rel = np.abs(a / np.abs(alpha).max())
    length = (2.6 if upper else 0.9) * (1.0 - 0.55 * rel**2)
    root = centre + (radius - 0.15) * radial
    tip = root + length[:, None] * (0.55 * radial + 0.84 * away)
    # spikes: roots all along the margin, tips at every lash, a valley between lashes
    valley = root + 0.7 * (tip - root)
    tips = np.where((np.arange(n) % 2 == 0)[:, None], tip, valley)
    verts = np.vstack([root, tips])
    i = np.arange(n - 1)
    tris = np.concatenate(
        [np.stack([i, i + 1, n + i + 1], -1), np.stack([i, n + i + 1, n + i], -1)]
    )
    e1, e2 = verts[tris[:, 1]] - verts[tris[:, 0]], verts[tris[:, 2]] - verts[tris[:, 0]]
    backwards = np.cross(e1, e2)[:, 2] < 0
    tris[backwards] = tris[backwards][:, ::-1]
    return verts, tris


def ellipsoid_mesh(centre, radii, colour, n_rings: int = 12, n_seg: int = 24) -> Part:
    """A UV ellipsoid with one colour (RGB + specular)."""
    polar = np.linspace(0, np.pi, n_rings)
    v, t, _ = _lathe(polar, np.zeros((n_rings, 4)), n_seg)
    verts = np.asarray(centre) + v[:, [0, 1, 2]] * np.asarray(radii)
    return Part(verts, t, np.tile(np.asarray(colour, dtype=float), (len(verts), 1)))
