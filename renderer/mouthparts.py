"""The built-in head's mouth: an oral cavity closed onto the lips, teeth and a tongue.

The cavity is a sack continued from the lips' inner edge (the slit of the skin grid,
:func:`renderer.headparts.skin_grid`): loops of vertices, each the lip margin's loop moved in
behind the lips, up along the palate and down along the floor of the mouth, narrowing to the
throat, where a cap closes it. It shares the margin's vertices, so no gap opens between lips
and cavity at any jaw opening or head turn (a separate ellipsoid behind the lips let the
neck and the background show through the open mouth, and at a turned head its side wall was
missing). The lower half of every loop follows the jaw by the weight of its lip vertex, the
upper half stays with the skull, the corners blend as the lip corners do, so the cavity's
side walls stretch with the opening instead of tearing. Teeth follow a dental arch and get
shorter towards the back (the upper and lower incisors meet at the lips' line, no corner
ends hang down as fangs); the tongue lies on the floor of the mouth behind the lower teeth
and moves with the jaw.

Model units are millimetres; axes as in :mod:`renderer.headmodel`.
"""

from __future__ import annotations

import numpy as np

from renderer.headparts import ellipsoid_mesh
from renderer.part import Part, merge
from renderer.sdf import smoothstep

#: The cavity's loops behind the lip margin: how far in (mm behind the lip vertex), how far up
#: (upper half) and down (lower half) at the midline, and how much wider than the lips.
CAVITY_ROWS = np.array(
    [
        # in, up, down, wider
        [1.5, 1.2, 1.2, 1.00],
        [4.5, 5.0, 5.0, 1.02],
        [9.0, 10.5, 10.0, 1.06],
        [17.0, 13.5, 13.0, 1.12],
        [31.0, 15.0, 14.0, 1.16],
        [50.0, 13.0, 14.0, 1.10],
        [64.0, 8.0, 10.0, 0.85],
        [70.0, 3.0, 4.0, 0.45],
    ]
)
MUCOSA = np.array([0.45, 0.17, 0.17])  # just inside the lips
THROAT = np.array([0.07, 0.015, 0.015])  # at the back, in shadow
TONGUE = np.array([0.60, 0.27, 0.28])
ENAMEL = np.array([0.90, 0.87, 0.79])
GUM = np.array([0.72, 0.36, 0.38])


def oral_cavity(margin: np.ndarray, lower: np.ndarray, jaw: np.ndarray, mouth_y: float) -> Part:
    """The cavity behind a lip margin: ``margin`` (n, 3) the margin's loop (the upper lip's
    inner edge from one corner to the other, then the lower lip's back; it wraps),
    ``lower`` marks the lower lip's vertices and ``jaw`` is each one's jaw weight.

    The first loop lies on the margin itself (the same positions and weights as the lips'
    vertices there, so it moves with them and no gap opens; its own vertices, so the
    cavity takes its colour per vertex while the lips take theirs from the skin texture).
    Triangles face into the cavity; every vertex is in ``hidden_outline`` (the lips'
    margins are what the edge overdraw draws).
    """
    half_width = float(np.abs(margin[:, 0]).max())
    across = np.clip(np.abs(margin[:, 0]) / half_width, 0.0, 1.0)
    arch = np.sqrt(1.0 - across**2) ** 0.7  # 1 at the midline, 0 at the corners
    sign = np.where(lower, -1.0, 1.0)
    corner = across >= 1.0 - 1e-6
    rows, colours, weights = [margin.astype(np.float64)], [MUCOSA], [jaw]
    for r, (depth, up, down, wider) in enumerate(CAVITY_ROWS):
        ring = margin.astype(np.float64)
        ring[:, 0] *= wider
        ring[:, 1] = mouth_y + sign * arch * np.where(lower, down, up)
        ring[:, 2] -= depth
        rows.append(ring)
        t = np.array((r + 1) / len(CAVITY_ROWS))
        colours.append(MUCOSA + (THROAT - MUCOSA) * smoothstep(0.0, 0.8, t))
        # the corners' weight blends to a half inside, as the cheeks' inner walls stretch
        weights.append(np.where(corner, jaw + smoothstep(0.0, 0.4, t) * (0.5 - jaw), jaw))
    n_loop, n_rows = len(margin), len(rows)
    throat = np.array([[0.0, mouth_y - 0.5, float(rows[-1][:, 2].mean()) - 2.0]])
    verts = np.vstack(rows + [throat])
    index = np.arange(n_rows * n_loop).reshape(n_rows, n_loop)
    c = np.arange(n_loop)
    a, b = index[:-1][:, c], index[:-1][:, (c + 1) % n_loop]
    d, e = index[1:][:, c], index[1:][:, (c + 1) % n_loop]
    tris = np.concatenate(
        [np.stack([a, b, e], -1).reshape(-1, 3), np.stack([a, e, d], -1).reshape(-1, 3)]
    )
    last = index[-1]
    cap = np.column_stack([last, np.roll(last, -1), np.full(n_loop, len(verts) - 1)])
    tris = np.vstack([tris, cap])
    # face into the cavity. The tube's cells all wind alike, so one cell decides for all:
    # the floor's, half way in at the midline, must face up; the cap must face forward
    p = verts[tris]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    tube = len(tris) - n_loop
    floor = int(np.argmin(np.abs(margin[:, 0]) + 1e3 * ~lower))
    probe = np.flatnonzero(tris[:tube, 0] == index[n_rows // 2, floor])[0]
    if normal[probe, 1] < 0:
        tris[:tube] = tris[:tube, ::-1]
    if normal[tube:, 2].sum() < 0:
        tris[tube:] = tris[tube:, ::-1]
    colour = np.vstack([np.tile(k, (n_loop, 1)) for k in colours] + [THROAT[None, :]])
    colour = np.column_stack([colour, np.full(len(colour), 0.25)])
    low = np.concatenate([lower.astype(float)] * n_rows + [np.zeros(1)])
    layers = {
        "jaw": np.concatenate(weights + [np.array([0.5])]),
        "lower_lip": low,
        "upper_lip": 1.0 - low,
    }
    everything = np.arange(len(verts))
    groups = {"hidden_outline": everything, "mouth_interior": everything}
    return Part(verts, tris, colour, groups, layers)


def _arch(radius: float, centre_z: float, n: int, reach_deg: float) -> tuple[np.ndarray, ...]:
    """Points along a dental arch (x, z) and each one's share of the way to its back end."""
    ang = np.radians(np.linspace(-reach_deg, reach_deg, n))
    # an arch narrower at the front than a circle: the incisors' curve, the molars' line
    x = radius * np.sin(ang) * (1.0 + 0.12 * np.abs(np.sin(ang)))
    z = centre_z + radius * np.cos(ang)
    return x, z, np.abs(ang) / np.radians(reach_deg)


def teeth(mouth_y: float) -> Part:
    """Upper teeth fixed to the skull, lower teeth on the jaw: each an arch of teeth (a band
    whose biting edge is scalloped per tooth, with darker gaps), shorter and shaded towards
    the back, with a strip of gum along its root."""
    parts = []
    # tooth boundaries along the arch (mm from the midline): incisors, canine, premolars
    edges = np.array([0.0, 8.5, 15.0, 22.0, 29.0, 36.0])
    for upper in (True, False):
        radius, centre_z = (19.0, 68.5) if upper else (17.5, 69.0)
        n = 41
        x, z, back = _arch(radius, centre_z, n, 84.0)
        s = np.abs(np.linspace(-1.0, 1.0, n)) * np.radians(84.0) * radius  # arc length
        tooth = np.searchsorted(edges, s, side="right") - 1
        within = (s - edges[tooth]) / np.diff(edges)[np.clip(tooth, 0, len(edges) - 2)]
        scallop = 0.7 * (1.0 - np.sin(np.pi * np.clip(within, 0, 1)))  # tips round off
        height = 7.0 - 3.5 * back**1.5 if upper else 6.0 - 2.5 * back**1.5
        edge_y = scallop + 1.8 * back**2  # the row rises towards the back
        if upper:
            ys = [mouth_y + 0.5 + edge_y, mouth_y + 0.5 + height, mouth_y + 0.5 + height + 2.5]
        else:
            ys = [mouth_y - 0.5 - edge_y, mouth_y - 0.5 - height, mouth_y - 0.5 - height - 2.5]
        v = np.vstack([np.column_stack([x, y, z - 0.6 * k]) for k, y in enumerate(ys)])
        tris = _band(3, n)
        if upper:  # rows run upwards: keep the outside (the front) counter-clockwise
            tris = tris[:, ::-1]
        shade = (1.0 - 0.55 * back**1.2)[:, None]
        gap = 1.0 - 0.35 * np.exp(-((within * np.diff(edges)[np.clip(tooth, 0, 4)]) ** 2) / 0.8)
        enamel = ENAMEL * shade * gap[:, None]
        col = np.vstack([enamel, enamel * 0.92, GUM * shade])
        part = Part(v, tris, np.column_stack([col, np.full(len(v), 0.45)]))
        part.colors[2 * n :, 3] = 0.2
        if not upper:
            part.layers["jaw"] = np.ones(len(v))
        parts.append(part)
    return merge(parts)


def _band(rows: int, cols: int) -> np.ndarray:
    """Two triangles per cell of a rows x cols grid, facing +z for rows running upwards."""
    r, c = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    a = (r * cols + c).ravel()
    return np.concatenate(
        [np.stack([a, a + cols, a + 1], -1), np.stack([a + 1, a + cols, a + cols + 1], -1)]
    )


def tongue(mouth_y: float) -> Part:
    """The tongue on the floor of the mouth, behind the lower incisors; moves with the jaw."""
    part = ellipsoid_mesh(
        (0.0, mouth_y - 11.5, 60.0), (16.0, 5.5, 20.0), np.append(TONGUE, 0.35), 10, 20
    )
    # a furrow along the midline and a darker back
    v = part.vertices
    part.vertices[:, 1] -= 1.2 * np.exp(-((v[:, 0] / 3.0) ** 2)) * (v[:, 1] > mouth_y - 11.5)
    part.colors[:, :3] *= (0.55 + 0.45 * smoothstep(40.0, 75.0, v[:, 2]))[:, None]
    part.layers["jaw"] = np.ones(len(v))
    return part


def mouth_parts(mouth_y: float) -> Part:
    """Teeth and tongue, their outlines hidden behind the lips."""
    mouth = merge([teeth(mouth_y), tongue(mouth_y)])
    mouth.groups["hidden_outline"] = np.arange(len(mouth.vertices))
    mouth.groups["mouth_interior"] = np.arange(len(mouth.vertices))
    return mouth
