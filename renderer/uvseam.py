"""Texture seams of the skin grid: where its azimuth wraps and at the crown's pole.

The skin's texture lies on its ray grid (:mod:`renderer.skintexture`): column ``j`` at
``u = (j + 0.5) / n``. Two places of the grid cannot take one ``u`` per vertex:

* the cells between the last column and the first, which wrap round the back of the head: a
  vertex of the first column has ``u`` near 0 for its own cells and would need ``u`` near 1
  for those, so one cell swept the whole texture row backwards, a stripe along the back and
  over the crown;
* the pole's fan: one pole vertex with one ``u`` made every triangle of the fan sweep from
  its column to the pole's, a swirl at the crown.

The usual cure (a seam, e.g. Botsch et al., "Polygon Mesh Processing", 2010, sec. 5.1) is a
twin of each vertex on the seam, at the same place with the other ``u``: the wrap cells use
twins of the first column with ``u + 1`` (the texture repeats across ``u``), and each fan
triangle its own pole twin with the ``u`` between its two columns. Twins split the mesh, so
their normals would split too (a shading seam): they are listed in the ``uv_seam`` group, and
:meth:`renderer.face.Face.normals` gives every vertex of that group the normal of all those at
its position. The twins' edges are left out of the edge overdraw (``hidden_outline``): the
surface is continuous across them.
"""

from __future__ import annotations

import numpy as np

from renderer.part import Part


def split_seams(part: Part, columns: np.ndarray, n_azimuth: int, pole: int) -> Part:
    """``part`` (the textured skin grid) with twins at its texture seams.

    ``columns`` gives each vertex's grid column (the pole's is ignored), ``pole`` the pole's
    index. Twins copy the vertex's position, colour, layers and groups but ``fp:`` ones.
    """
    assert part.uvs is not None
    tris = part.triangles.copy()
    verts, uvs = [part.vertices], [part.uvs]
    sources: list[np.ndarray] = []
    n = len(part.vertices)
    col = np.asarray(columns)[tris]
    is_pole = tris == pole
    # the wrap cells: a corner in the last column; their first-column corners get twins
    wrap = ((col == n_azimuth - 1) & ~is_pole).any(axis=1)
    first = wrap[:, None] & (col == 0) & ~is_pole
    old = np.unique(tris[first])
    twin = dict(zip(old.tolist(), range(n, n + len(old)), strict=True))
    tris[first] = [twin[int(i)] for i in tris[first]]
    wrapped = part.uvs[old].copy()
    wrapped[:, 0] += 1.0
    verts.append(part.vertices[old])
    uvs.append(wrapped)
    sources.append(old)
    n += len(old)
    # the pole's fan: one twin per triangle, u half way between its other two corners
    fan = np.flatnonzero(is_pole.any(axis=1))
    if len(fan):
        u_now = np.vstack(uvs)[:, 0][tris[fan]]
        u = np.where(is_pole[fan], 0.0, u_now).sum(axis=1) / 2.0
        pole_uv = np.tile(part.uvs[pole], (len(fan), 1))
        pole_uv[:, 0] = u
        tris[fan] = np.where(is_pole[fan], n + np.arange(len(fan))[:, None], tris[fan])
        verts.append(np.tile(part.vertices[pole], (len(fan), 1)))
        uvs.append(pole_uv)
        sources.append(np.full(len(fan), pole))
    src = np.concatenate(sources)
    groups = {k: v for k, v in part.groups.items()}
    base = len(part.vertices)
    new = np.arange(base, base + len(src))
    for name, members in part.groups.items():
        if name.startswith("fp:") or name == "mouth_loop":
            continue
        groups[name] = np.concatenate([members, new[np.isin(src, members)]])
    seam = np.concatenate([np.unique(src), new])
    groups["uv_seam"] = seam
    groups["hidden_outline"] = np.union1d(groups.get("hidden_outline", np.zeros(0, int)), seam)
    return Part(
        vertices=np.vstack(verts),
        triangles=tris,
        colors=np.vstack([part.colors, part.colors[src]]),
        groups=groups,
        layers={k: np.concatenate([v, v[src]]) for k, v in part.layers.items()},
        uvs=np.vstack(uvs).astype(np.float32),
    )
