"""Silhouette and boundary edges of a posed mesh, for discontinuity edge overdraw.

Anti-aliasing by *discontinuity edge overdraw* (Sander, Hoppe, Snyder & Gortler, "Discontinuity
Edge Overdraw", ACM I3D 2001): the mesh is drawn aliased, then every edge where the visible
surface ends - a silhouette (one adjacent triangle faces the camera, the other away) or an open
boundary (lip and eyelid margins) - is drawn again as a thin blended strip whose coverage falls
off with the pixel's distance from the edge, on the outside of the edge only, with depth test and
no depth writes. On a software rasteriser this costs a few hundred thin strips per face instead of
four samples per pixel for every triangle (multisampling triples llvmpipe's draw time).

This module is the numpy half: the mesh's edge table (built once) and, per frame, the edges to
overdraw, each with the vertex opposite it in its front-facing triangle (which tells the
geometry shader which side of the edge is inside). See :class:`renderer.gl.FaceCanvas`.

Example
-------
>>> import numpy as np
>>> tris = np.array([[0, 1, 2], [0, 2, 3]])    # a square of two triangles
>>> table = edge_table(tris)
>>> len(table.a), int((table.t1 < 0).sum())   # 5 edges, 4 of them on the boundary
(5, 4)
>>> xyw = np.array([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)  # facing us
>>> len(overdraw_edges(table, tris, xyw))     # the outline
4
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class EdgeTable:
    """The edges of a triangle mesh with their (up to two) adjacent triangles.

    ``a``, ``b``: end vertices; ``t0``, ``t1``: adjacent triangles (``t1`` is -1 on an open
    boundary); ``o0``, ``o1``: the vertex opposite the edge in ``t0`` / ``t1``. An edge shared by
    more than two triangles (non-manifold) keeps its first two.
    """

    a: np.ndarray
    b: np.ndarray
    t0: np.ndarray
    t1: np.ndarray
    o0: np.ndarray
    o1: np.ndarray

    @cached_property
    def rows(self) -> tuple[np.ndarray, np.ndarray]:
        """int32 ``(a, b, o0)`` and ``(a, b, o1)`` rows, ready to upload."""
        return (
            np.column_stack([self.a, self.b, self.o0]).astype(np.int32),
            np.column_stack([self.a, self.b, self.o1]).astype(np.int32),
        )


def edge_table(triangles: np.ndarray, hidden: np.ndarray | None = None) -> EdgeTable:
    """Build the :class:`EdgeTable` of ``triangles`` (m, 3) vertex indices.

    ``hidden``: optional boolean per vertex; edges with both ends hidden (an outline that never
    shows, such as an eyeball's under the lids) are left out.
    """
    t = np.asarray(triangles, dtype=np.int64)
    m = len(t)
    # every triangle's three edges, with the triangle and the vertex opposite each edge
    a = t[:, [0, 1, 2]].ravel()
    b = t[:, [1, 2, 0]].ravel()
    opposite = t[:, [2, 0, 1]].ravel()
    tri = np.repeat(np.arange(m), 3)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    order = np.lexsort((tri, hi, lo))
    lo, hi, tri, opposite = lo[order], hi[order], tri[order], opposite[order]
    first = np.ones(len(lo), bool)
    first[1:] = (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])
    starts = np.flatnonzero(first)
    ends = np.append(starts[1:], len(lo))
    paired = ends - starts >= 2
    t1 = np.full(len(starts), -1, np.int64)
    o1 = np.full(len(starts), -1, np.int64)
    t1[paired] = tri[starts[paired] + 1]
    o1[paired] = opposite[starts[paired] + 1]
    table = EdgeTable(lo[starts], hi[starts], tri[starts], t1, opposite[starts], o1)
    if hidden is None:
        return table
    keep = ~(hidden[table.a] & hidden[table.b])
    return EdgeTable(*(getattr(table, k)[keep] for k in ("a", "b", "t0", "t1", "o0", "o1")))


def front_facing(triangles: np.ndarray, xyw: np.ndarray) -> np.ndarray:
    """Which triangles face the camera: counter-clockwise in normalised device coordinates.

    ``triangles``: (m, 3) vertex indices; ``xyw``: (n, 3) clip-space x, y and w of the
    vertices. Triangles with a vertex behind the camera (w <= 0) count as facing away.
    """
    w = xyw[:, 2]
    behind = w <= 0
    safe_w = np.where(behind, 1.0, w) if behind.any() else w
    x, y = xyw[:, 0] / safe_w, xyw[:, 1] / safe_w
    i0, i1, i2 = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    x0, y0 = x.take(i0), y.take(i0)  # (take: faster than indexing, this runs every frame)
    area = (x.take(i1) - x0) * (y.take(i2) - y0) - (x.take(i2) - x0) * (y.take(i1) - y0)
    front = area > 0
    if behind.any():
        front &= ~(behind[i0] | behind[i1] | behind[i2])
    return front


def overdraw_edges(table: EdgeTable, triangles: np.ndarray, xyw: np.ndarray) -> np.ndarray:
    """The edges to overdraw this frame as int32 (k, 3) rows ``(a, b, opposite)``.

    An edge qualifies when exactly one adjacent triangle faces the camera (a silhouette) or
    when it is an open boundary of a front-facing triangle; ``opposite`` is the third vertex
    of that front-facing triangle.
    """
    front = np.append(front_facing(triangles, xyw), False)  # t1 = -1 (no second) reads False
    f0, f1 = front.take(table.t0), front.take(table.t1)
    rows0, rows1 = table.rows
    return np.concatenate(
        [rows0.take(np.flatnonzero(f0 & ~f1), axis=0), rows1.take(np.flatnonzero(f1 & ~f0), axis=0)]
    )
