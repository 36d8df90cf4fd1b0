"""The face model the renderer animates: a triangle mesh plus its MPEG-4 feature points and FAPU.

A :class:`Face` is what both the built-in parametric head (:mod:`renderer.headmodel`) and a
bring-your-own OBJ + JSON face (:mod:`renderer.objface`) produce. It carries the neutral mesh,
per-vertex colours, the MPEG-4 feature points (FDP, ISO/IEC 14496-2 Annex C; see the project's
``mpeg4-fap`` reference) and the FAPU distances measured on the neutral face, plus the vertex
groups the deformation needs (eyeballs rotate as rigid parts, the lower lip follows the jaw:
Parke's parameterised face keeps upper and lower lip unconnected, thesis sec. 2.1.2).

Axes follow Xface: +x is the face's own left, +y up, +z forward (towards the camera).

Example
-------
>>> from renderer.headmodel import builtin_face
>>> face = builtin_face()
>>> round(face.fapu["ES0"]) > 0, "2.1" in face.feature_points
(True, True)
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from app.stimuli.fap import FAPU_DISTANCE

#: Feature points every face must define (the ones the deformation and the mosaic use).
REQUIRED_FEATURE_POINTS: tuple[str, ...] = (
    "2.1",
    "2.2",
    "2.3",
    "2.4",
    "2.5",
    "2.6",
    "2.7",
    "2.8",
    "2.9",
    "2.10",
    "3.1",
    "3.2",
    "3.3",
    "3.4",
    "3.5",
    "3.6",
    "4.1",
    "4.2",
    "4.3",
    "4.4",
    "4.5",
    "4.6",
    "7.1",
    "8.1",
    "8.2",
    "8.3",
    "8.4",
    "8.5",
    "8.6",
    "8.7",
    "8.8",
    "9.15",
)

#: Feature points whose projected box is the mouth region hidden by the mosaic.
MOUTH_FEATURE_POINTS: tuple[str, ...] = (
    "2.2",
    "2.3",
    "2.4",
    "2.5",
    "2.6",
    "2.7",
    "2.8",
    "2.9",
    "8.1",
    "8.2",
    "8.3",
    "8.4",
    "8.5",
    "8.6",
    "8.7",
    "8.8",
)

FAPU_NAMES: tuple[str, ...] = tuple(FAPU_DISTANCE.values())

#: Vertex groups every face must define.
REQUIRED_GROUPS: tuple[str, ...] = ("eyeball_l", "eyeball_r")

#: Optional vertex groups: ``hidden_outline`` marks vertices whose outline never shows (inside
#: the head, under the skin); edges between two of them are not anti-aliased
#: (:mod:`renderer.edges`).
#: ``uv_seam`` marks vertices split for the texture only (twins at one position with different
#: texture coordinates): they share one normal (:meth:`Face.normals`).
#: ``mouth_interior`` marks the inside of the mouth (cavity, teeth, tongue), which closed lips
#: hide: the mosaic's face, drawn with the mouth at rest, is drawn without it.
OPTIONAL_GROUPS: tuple[str, ...] = ("hidden_outline", "uv_seam", "mouth_interior")

#: Optional per-vertex weight layers (0..1) a face may supply instead of the derived defaults.
WEIGHT_LAYERS: tuple[str, ...] = (
    "head",
    "jaw",
    "upper_lip",
    "lower_lip",
    "eyelid_upper_l",
    "eyelid_upper_r",
    "eyelid_lower_l",
    "eyelid_lower_r",
)


@dataclass(eq=False)
class Face:
    """A neutral face mesh with its MPEG-4 feature points and FAPU.

    Attributes
    ----------
    vertices : float32 (n, 3) neutral positions in model units.
    triangles : int32 (m, 3) vertex indices, counter-clockwise seen from outside.
    colors : float32 (n, 4) RGB in 0..1 and a specular strength in the 4th column.
    feature_points : name (e.g. ``"2.1"``) -> (3,) float64 neutral position.
    fp_vertices : name -> vertex index for feature points that sit on the mesh (the mouth
        box follows these vertices as they deform).
    fapu : ``ES0, IRISD0, ENS0, MNS0, MW0`` in model units (not yet divided by 1024).
    groups : name -> int vertex indices (``eyeball_l``, ``eyeball_r``, optional
        ``hidden_outline``).
    weights : optional per-vertex weight layers (see :data:`WEIGHT_LAYERS`).
    jaw_pivot : (3,) point on the jaw hinge axis (the axis is parallel to x).
    name : label for logs and cache keys.
    uvs : optional float32 (n, 2) texture coordinates (u right, v up, as OpenGL samples).
    texture : optional uint8 (h, w, 3) albedo, display-referred, row 0 at v = 0; with
        ``uvs`` the renderer multiplies each pixel's colour by it (sampled per pixel).
    """

    vertices: np.ndarray
    triangles: np.ndarray
    colors: np.ndarray
    feature_points: dict[str, np.ndarray]
    fp_vertices: dict[str, int]
    fapu: dict[str, float]
    groups: dict[str, np.ndarray]
    weights: dict[str, np.ndarray] = field(default_factory=dict)
    jaw_pivot: np.ndarray | None = None
    name: str = "face"
    uvs: np.ndarray | None = None
    texture: np.ndarray | None = None

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_triangles(self) -> int:
        return int(self.triangles.shape[0])

    def eye_centre(self, side: str) -> np.ndarray:
        """Rotation centre of eyeball ``side`` (``"l"`` or ``"r"``): the centre of the sphere
        fitted to its vertices (least squares), or their bounding-box centre when they do not
        span a sphere.

        An eyeball mesh is often open at the back (it is never seen); its bounding box then
        centres in front of the ball's centre, and turning about that point swings the ball out
        of its socket. The algebraic sphere fit ``|p|^2 = 2 c . p + k`` (linear in ``c``, ``k``)
        finds the true centre from any patch of the sphere.
        """
        v = self.vertices[self.groups[f"eyeball_{side}"]].astype(np.float64)
        box = (v.min(axis=0) + v.max(axis=0)) / 2.0
        if len(v) < 4:
            return box
        q = v - box  # centred, for conditioning
        a = np.column_stack([2.0 * q, np.ones(len(q))])
        coef, _, rank, _ = np.linalg.lstsq(a, (q * q).sum(axis=1), rcond=None)
        centre = box + coef[:3]
        radius2 = coef[3] + coef[:3] @ coef[:3]
        fits = (
            rank == 4
            and radius2 > 0
            and np.abs(np.linalg.norm(v - centre, axis=1) - np.sqrt(radius2)).max()
            < 0.05 * np.sqrt(radius2)
        )
        return centre if fits else box

    def pivot(self) -> np.ndarray:
        """Head rotation pivot: feature point 7.1 (top of the spine)."""
        return np.asarray(self.feature_points["7.1"], dtype=np.float64)

    def hinge(self) -> np.ndarray:
        """A point on the jaw hinge axis; defaults to below the eyes, at the depth of 7.1."""
        if self.jaw_pivot is not None:
            return np.asarray(self.jaw_pivot, dtype=np.float64)
        eyes_y = (self.feature_points["3.5"][1] + self.feature_points["3.6"][1]) / 2.0
        return np.array([0.0, eyes_y - 0.5 * self.fapu["ENS0"], self.pivot()[2]])

    def normals(self) -> np.ndarray:
        """Area-weighted vertex normals of the neutral mesh, float32 (n, 3); the vertices of
        the ``uv_seam`` group that share a position share their summed normal."""
        seam = self.groups.get("uv_seam")
        if seam is None or not len(seam):
            return vertex_normals(self.vertices, self.triangles)
        return vertex_normals(self.vertices, self.triangles, weld=np.asarray(seam))

    def content_hash(self) -> str:
        """SHA-256 of everything that changes how the face renders (for the clip cache)."""
        h = hashlib.sha256()
        for arr in (self.vertices, self.triangles, self.colors):
            h.update(np.ascontiguousarray(arr).tobytes())
        for name in sorted(self.feature_points):
            h.update(name.encode())
            h.update(np.asarray(self.feature_points[name], dtype=np.float64).tobytes())
        for name in sorted(self.fp_vertices):
            h.update(f"{name}={self.fp_vertices[name]}".encode())
        for name in sorted(self.fapu):
            h.update(f"{name}={self.fapu[name]!r}".encode())
        for store in (self.groups, self.weights):
            for name in sorted(store):
                h.update(name.encode())
                h.update(np.ascontiguousarray(store[name]).tobytes())
        if self.jaw_pivot is not None:
            h.update(np.asarray(self.jaw_pivot, dtype=np.float64).tobytes())
        if self.uvs is not None and self.texture is not None:
            h.update(np.ascontiguousarray(self.uvs).tobytes())
            h.update(np.ascontiguousarray(self.texture).tobytes())
        return h.hexdigest()

    @property
    def textured(self) -> bool:
        """Whether the face carries an albedo texture and the coordinates to sample it."""
        return self.uvs is not None and self.texture is not None


def fapu_from_feature_points(fp: dict[str, np.ndarray]) -> dict[str, float]:
    """FAPU distances measured on the neutral face, as MPEG-4 defines them.

    ES0 = pupil separation (3.5-3.6), IRISD0 = upper to lower eyelid (3.1-3.3), ENS0 = eye line
    to nose bottom (y of 3.5/3.6 to 9.15), MNS0 = nose bottom to mouth (9.15 to 2.2), MW0 =
    lip corner separation (8.3-8.4).
    """
    eye_y = (fp["3.5"][1] + fp["3.6"][1]) / 2.0
    return {
        "ES0": float(np.linalg.norm(fp["3.5"] - fp["3.6"])),
        "IRISD0": float(np.linalg.norm(fp["3.1"] - fp["3.3"])),
        "ENS0": float(eye_y - fp["9.15"][1]),
        "MNS0": float(fp["9.15"][1] - fp["2.2"][1]),
        "MW0": float(np.linalg.norm(fp["8.3"] - fp["8.4"])),
    }


def vertex_normals(
    vertices: np.ndarray, triangles: np.ndarray, weld: np.ndarray | None = None
) -> np.ndarray:
    """Area-weighted vertex normals (unit length; zero-area vertices get +z).

    ``weld``: vertex indices among which those at one position sum their normals (twins
    split for the texture, :mod:`renderer.uvseam`).
    """
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles)
    fn = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, t[:, k], fn)
    if weld is not None and len(weld):
        _, place = np.unique(v[weld], axis=0, return_inverse=True)
        summed = np.zeros((int(place.max()) + 1, 3))
        np.add.at(summed, place.ravel(), n[weld])
        n[weld] = summed[place.ravel()]
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(length > 1e-12, n / np.maximum(length, 1e-12), np.array([0.0, 0.0, 1.0]))
    return n.astype(np.float32)
