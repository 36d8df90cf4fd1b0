"""Parts of the skin that translational FAPs move, and the normals their motion changes.

The translational FAPs (lips, brows; :mod:`renderer.deform`) stretch and shear the skin; its
neutral normals would then shade a stretched forehead or cheek as if it still had its old
slope (a raised brow darkened the whole upper lid). A :class:`SkinPart` holds the
displacement basis of a group of FAPs on the vertices they move and recomputes the normals of
every vertex whose triangles they move (the zone and its one-ring), so a part at rest costs
nothing and the mouth's and the brows' normals are recomputed only when they move.

Example
-------
>>> import numpy as np
>>> tri = np.array([[0, 1, 2], [1, 3, 2], [3, 4, 2]])
>>> one_ring(tri, np.array([0]), 5).tolist()
[0, 1, 2]
"""

from __future__ import annotations

import numpy as np


def one_ring(triangles: np.ndarray, vertices: np.ndarray, n_vertices: int) -> np.ndarray:
    """Sorted vertex indices of every triangle touching ``vertices`` (``vertices`` included)."""
    inside = np.zeros(n_vertices, bool)
    inside[vertices] = True
    touching = np.asarray(triangles)[inside[triangles].any(axis=1)]
    inside[touching.ravel()] = True
    return np.flatnonzero(inside)


class ZoneNormals:
    """Area-weighted normals of the vertices of a zone, recomputed from deformed positions.

    Only triangles touching the zone take part, gathered by one sparse product, so this costs
    a fraction of a millisecond. Equal to :func:`renderer.face.vertex_normals` on the zone.
    """

    def __init__(self, triangles: np.ndarray, zone: np.ndarray, n_vertices: int) -> None:
        from scipy import sparse

        self.zone = np.asarray(zone)
        in_zone = np.zeros(n_vertices, bool)
        in_zone[zone] = True
        self.triangles = np.asarray(triangles)[in_zone[triangles].any(axis=1)]
        self._corners = [np.ascontiguousarray(self.triangles[:, k]) for k in range(3)]
        row_of = np.full(n_vertices, -1)
        row_of[zone] = np.arange(len(zone))
        rows = row_of[self.triangles].ravel()
        cols = np.repeat(np.arange(len(self.triangles)), 3)
        keep = rows >= 0
        self.gather = sparse.csr_matrix(
            (np.ones(int(keep.sum()), np.float32), (rows[keep], cols[keep])),
            shape=(len(zone), len(self.triangles)),
        )

    def __call__(self, positions: np.ndarray) -> np.ndarray:
        # np.take of whole rows and a written-out cross product: a third of the time of
        # fancy indexing and np.cross on these few thousand triangles
        a, b, c = self._corners
        p0 = np.take(positions, a, axis=0)
        e1 = np.take(positions, b, axis=0)
        e1 -= p0
        e2 = np.take(positions, c, axis=0)
        e2 -= p0
        face_normals = np.column_stack(
            [
                e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1],
                e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2],
                e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0],
            ]
        )
        n = self.gather @ face_normals
        length = np.sqrt(np.einsum("ij,ij->i", n, n))[:, None]
        out = (n / np.maximum(length, 1e-12)).astype(np.float32)
        out[length[:, 0] <= 1e-12] = (0.0, 0.0, 1.0)
        return out


class SkinPart:
    """The translational FAPs of one part of the face (columns of a displacement basis).

    ``columns`` indexes the FAPs of the part in ``basis`` (k, n, 3), the displacement of every
    vertex per unit FAP value; the part keeps the columns only on the vertices they move
    (:attr:`zone`) and the normals of those vertices and their one-ring (:attr:`normals`).
    """

    def __init__(self, columns: np.ndarray, basis: np.ndarray, triangles: np.ndarray) -> None:
        n_vertices = basis.shape[1]
        self.columns = np.asarray(columns)
        part = basis[self.columns]
        self.zone = np.flatnonzero(np.abs(part).sum(axis=(0, 2)) > 1e-9)
        self.basis = part[:, self.zone, :].reshape(len(self.columns), -1).astype(np.float32)
        self.normals = ZoneNormals(
            triangles, one_ring(triangles, self.zone, n_vertices), n_vertices
        )

    def move(self, coeff: np.ndarray, positions: np.ndarray) -> bool:
        """Add the part's displacement for FAP values ``coeff`` (all columns of the basis) to
        ``positions`` in place; whether it moved anything."""
        c = coeff[self.columns]
        active = np.flatnonzero(c)
        if not len(active):
            return False
        positions[self.zone] += (c[active] @ self.basis[active]).reshape(-1, 3)
        return True

    def shade(self, positions: np.ndarray, normals: np.ndarray) -> None:
        """Recompute, in place, the normals the part's motion changes."""
        normals[self.normals.zone] = self.normals(positions)
