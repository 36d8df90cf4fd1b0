"""A face whose vertices are given per frame: a mesh sequence drawn as every face is.

A mesh condition (:mod:`app.stimuli.meshes`: a vertex sequence of any topology, or FLAME
parameters made into one) is drawn by the same canvas, camera, lights, background and mosaic
as the built-in head and avatars (:mod:`renderer.pipeline`). What the renderer needs of a face
it finds on the mesh (:func:`mesh_face`):

* the mouth's feature points (2.2-2.9, 8.1-8.8) from the lip vertices: a region file's, else
  those found from the motion that follows the speech's energy
  (:func:`app.stimuli.meshes.regions.find_lips`);
* the eyes (3.5, 3.6): the eyeballs' fronts where the mesh has eyeballs, else where a head's
  proportions put them (0.45 W above the mouth, 0.41 W apart, W the head's width); the camera
  is framed on them and the mouth (:func:`renderer.camera.camera_for`), so by the mesh's own size;
* the head's pivot (7.1): FLAME's neck joint, else below and behind the eyes as on the built-in
  head; the head turns (FAPs 48-50) about it, rigidly, or as far as FLAME's skinning to the
  neck and above says (:meth:`renderer.deform.Rig.posed`), and the eyeballs turn with the gaze
  (FAPs 23-26) where there are eyeballs;
* the mouth's inside, which the projects' meshes lack: a dark backdrop behind the lips
  (:func:`mouth_cavity`), appended after the sequence's vertices.

The mouth at rest (what the mosaic's face shows, :meth:`MeshRig.at_rest`) is the frame with the
lower face's own motion taken back to the template: each vertex by its weight in the
:attr:`MeshFace.lower_face` ramp (1 below 35 % of the way from the mouth up to the eyes, 0 above
55 %, the avatars' ceiling: :class:`renderer.avatar.AvatarRig`), the eyeballs never. Above it the
mesh moves as its file says (brows, lids). No mosaic block covers :attr:`MeshFace.upper_face`:
the eyeballs and what lies around each eye, from a quarter of the eye distance below it to half
of it above (the lids and brows), not the cheeks and the nose towards the mouth.

Example
-------
>>> import numpy as np
>>> from app.stimuli.meshes.sequence import MeshSequence
>>> grid = np.array([[x, y, 0.0] for y in np.linspace(-0.1, 0.1, 9)
...                  for x in np.linspace(-0.08, 0.08, 9)])
>>> tris = np.array([[i, i + 1, i + 9] for i in range(71) if i % 9 != 8])
>>> frames = np.repeat(grid[None], 2, axis=0).astype(np.float32)
>>> frames[1, grid[:, 1] < -0.02, 1] -= 0.01  # the lower part drops, as a jaw does
>>> face = mesh_face(MeshSequence(grid, tris, frames, 30.0, "plate.npy"))
>>> round(float(grid[face.fp_vertices["2.3"], 1]), 3)  # the lower lip: the top of what drops
-0.025
>>> float(face.lower_face[0]), float(face.lower_face[-1])  # the chin at rest, the brow not
(1.0, 0.0)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from app.stimuli.meshes.regions import (
    EYE_SPACING_W,
    EYES_ABOVE_MOUTH_W,
    MouthPoints,
    find_lips,
    mouth_points_of,
)
from app.stimuli.meshes.sequence import MeshSequence
from renderer.deform import EYE_TURNS, HEAD_TURNS, FaceFrame, Rig, about, fap_rotation
from renderer.face import MOUTH_FEATURE_POINTS, Face, fapu_from_feature_points
from renderer.skin import ZoneNormals

#: The mesh's colours: skin (as the plain built-in head's), lips, sclera, iris; the fourth
#: column is the specular strength.
SKIN = (0.80, 0.60, 0.50, 0.35)
LIPS = (0.72, 0.42, 0.40, 0.45)
SCLERA = (0.90, 0.88, 0.84, 0.5)
IRIS = (0.22, 0.14, 0.09, 0.5)
#: The mouth's cavity (see :func:`mouth_cavity`): the dark red of the built-in head's.
CAVITY = (0.16, 0.05, 0.05, 0.0)
#: The lower face's ramp: fractions of the way from the mouth up to the eyes.
LOWER_FACE_RAMP = (0.35, 0.55)


@dataclass(eq=False)
class MeshFace(Face):
    """A :class:`Face` made from a mesh sequence's template (see the module's docstring).

    sequence : the sequence the frames come from.
    lower_face : (V,) how far each vertex's motion is the mouth's (taken back at rest).
    upper_face : the vertices the mosaic never covers (the eyes, lids and brows).
    mouth : the mouth found (or named) on the mesh.
    """

    sequence: MeshSequence | None = None
    lower_face: np.ndarray = field(default_factory=lambda: np.zeros(0))
    upper_face: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    mouth: MouthPoints | None = None
    notes: list[str] = field(default_factory=list)

    def content_hash(self) -> str:
        import hashlib

        cached = self.__dict__.get("_hash")
        if cached is None:
            h = hashlib.sha256(super().content_hash().encode())
            assert self.sequence is not None
            h.update(self.sequence.digest().encode())
            h.update(np.ascontiguousarray(self.lower_face).tobytes())
            cached = self.__dict__["_hash"] = h.hexdigest()
        return cached


def _colors(seq: MeshSequence, lips: np.ndarray, pupils: dict[str, np.ndarray]) -> np.ndarray:
    colors = np.tile(np.array(SKIN, dtype=np.float32), (seq.n_vertices, 1))
    colors[lips] = LIPS
    if seq.eyeballs is not None:
        for ball in seq.eyeballs:
            v = seq.template[ball]
            centre = (v.min(axis=0) + v.max(axis=0)) / 2.0
            radius = max(float(np.ptp(v[:, 0])) / 2.0, 1e-9)
            toward = (v - centre) @ np.array([0.0, 0.0, 1.0]) / radius
            colors[ball] = np.where((toward > 0.75)[:, None], IRIS, SCLERA)
    return colors


def mouth_cavity(
    v: np.ndarray,
    triangles: np.ndarray,
    mouth: MouthPoints,
    centre: np.ndarray,
    lips_reach: tuple[float, float] = (0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """A dark backdrop behind the lips: ``(points (C, 3), triangles (K, 3))``, indices from 0.

    The projects' meshes (FLAME's, BIWI's scans) have no inside to the mouth: drawn with back
    faces culled, an open mouth would show the background through the head, where the built-in
    head shows its dark cavity. A rectangle facing forward, from 1.4 half mouth widths
    to either side of the lips' middle, 0.6 up and 1.0 down (the lower lip drops), or 1.3 times
    as far as the lips reach up and down in the clip (``lips_reach``: metres above and below
    the middle) where that is further, in each direction within 85 % of the face's reach from
    the lips; 0.3 half widths behind the lips, or 0.1 behind the face's front surface (its four
    nearest forward-facing vertices, weighted by inverse distance) where that is further back,
    so it shows only through the mouth. It turns with the head and never moves with the lips:
    the mouth at rest hides it, and the mosaic's blocks are unchanged.
    """
    left, right = mouth.corners
    half = max(abs(float(v[left, 0] - v[right, 0])) / 2.0, 1e-6)
    rings, segments = 3, 24
    angle = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    radius = np.linspace(0.0, 1.0, rings + 1)[1:]
    rr, aa = np.meshgrid(radius, angle, indexing="ij")
    up, down = max(0.6 * half, 1.3 * lips_reach[0]), max(half, 1.3 * lips_reach[1])
    # a rectangle's outline (an open mouth's corners are square where the jaw drops)
    square = rr / np.maximum(np.abs(np.cos(aa)), np.abs(np.sin(aa)))
    dy = np.where(np.sin(aa) > 0, up, down) * square * np.sin(aa)
    ring_points = np.stack(
        [centre[0] + 1.4 * half * square * np.cos(aa), centre[1] + dy, np.zeros_like(rr)],
        axis=-1,
    ).reshape(-1, 3)
    plane = float(centre[2]) - 0.3 * half
    a, b, c = v[triangles[:, 0]], v[triangles[:, 1]], v[triangles[:, 2]]
    facing = np.zeros(len(v))
    np.add.at(facing, triangles.ravel(), np.repeat(np.cross(b - a, c - a)[:, 2], 3))
    front = v[facing > 0]
    if len(front):  # in each direction, within 85 % of the face's reach from the lips
        off = front[:, :2] - centre[None, :2]
        turn = np.angle(np.exp(1j * (np.arctan2(off[:, 1], off[:, 0])[None] - angle[:, None])))
        sector = np.abs(turn) < np.pi / segments
        reach = np.where(sector, np.hypot(off[:, 0], off[:, 1])[None], 0.0).max(axis=1)
        outline = np.hypot(
            ring_points[-segments:, 0] - centre[0], ring_points[-segments:, 1] - centre[1]
        )
        shrink = np.minimum(1.0, 0.85 * reach / np.maximum(outline, 1e-12))
        ring_points[:, :2] = (
            centre[None, :2]
            + (ring_points[:, :2] - centre[None, :2]) * np.tile(shrink, rings)[:, None]
        )
    points = np.vstack([[centre[0], centre[1], 0.0], ring_points])
    depth = np.full(len(points), plane)
    if len(front):  # the face's front surface at each point: its 4 nearest vertices, weighted
        dist = np.hypot(
            points[:, None, 0] - front[None, :, 0], points[:, None, 1] - front[None, :, 1]
        )
        k = min(4, len(front))
        nearest = np.argpartition(dist, k - 1, axis=1)[:, :k]
        weight = 1.0 / np.maximum(np.take_along_axis(dist, nearest, axis=1), 1e-9)
        surface = (front[nearest, 2] * weight).sum(axis=1) / weight.sum(axis=1)
        depth = np.minimum(depth, surface - 0.1 * half)
    points[:, 2] = depth
    rows = 1 + np.arange(rings * segments).reshape(rings, segments)
    nxt = np.roll(rows, -1, axis=1)
    fan = np.stack([np.zeros(segments, np.int64), rows[0], nxt[0]], axis=1)
    quads = [np.stack([rows[i], rows[i + 1], nxt[i + 1]], axis=1) for i in range(rings - 1)] + [
        np.stack([rows[i], nxt[i + 1], nxt[i]], axis=1) for i in range(rings - 1)
    ]
    return points, np.vstack([fan, *quads])


def mesh_face(seq: MeshSequence, energy: np.ndarray | None = None) -> MeshFace:
    """The face of ``seq`` (see the module's docstring); ``energy``: the speech's energy per
    frame of the sequence, for finding the lips where no region file names them."""
    v = seq.template
    width = float(np.ptp(v[:, 0]))
    eyes = np.concatenate(seq.eyeballs) if seq.eyeballs is not None else np.zeros(0, np.int64)
    notes = list(seq.notes)
    if seq.lips is not None:
        mouth = mouth_points_of(v, seq.lips)
    else:
        mouth = find_lips(v, seq.frames, energy, exclude=eyes, name=seq.label)
        how = "the motion that follows the speech" if energy is not None else "the motion"
        notes.append(f"{seq.label}: {len(mouth.lips)} lip vertices found from {how}")
    centre = (v[mouth.upper] + v[mouth.lower]) / 2.0
    centre[0] = mouth.midline
    pupils: dict[str, np.ndarray] = {}
    if seq.eyeballs is not None:
        for side, ball in zip(("l", "r"), seq.eyeballs, strict=True):
            b = v[ball]
            mid = (b.min(axis=0) + b.max(axis=0)) / 2.0
            pupils[side] = np.array([mid[0], mid[1], b[:, 2].max()])
    else:
        eye_y = centre[1] + EYES_ABOVE_MOUTH_W * width
        half = EYE_SPACING_W * width / 2.0
        for side, sign in (("l", 1.0), ("r", -1.0)):
            guess = np.array([mouth.midline + sign * half, eye_y, centre[2]])
            near = np.abs(v[:, 0] - guess[0]) + np.abs(v[:, 1] - guess[1])
            front = v[near < 0.05 * width]
            z = float(front[:, 2].max()) - 0.02 * width if len(front) else centre[2]
            pupils[side] = np.array([guess[0], eye_y, z])
    eye_mid = (pupils["l"] + pupils["r"]) / 2.0
    es = float(np.linalg.norm(pupils["l"] - pupils["r"]))
    pivot = (
        np.asarray(seq.pivot, dtype=np.float64)
        if seq.pivot is not None
        else eye_mid + np.array([0.0, -0.87, -1.61]) * es  # the built-in head's proportions
    )
    fp_vertices = _mouth_vertices(v, mouth)
    points = {k: v[i].astype(np.float64) for k, i in fp_vertices.items()}
    points.update({"3.5": pupils["l"], "3.6": pupils["r"], "7.1": pivot})
    points.setdefault("3.1", pupils["l"] + [0.0, 0.1 * es, 0.0])
    points.setdefault("3.3", pupils["l"] - [0.0, 0.1 * es, 0.0])
    points.setdefault("9.15", eye_mid + 0.62 * (centre - eye_mid))
    # the lower face's ramp, from the mouth up to the eyes; eyeballs never
    rise = max(float(eye_mid[1] - centre[1]), 1e-9)
    lo, hi = (centre[1] + f * rise for f in LOWER_FACE_RAMP)
    lower = np.clip((hi - v[:, 1]) / (hi - lo), 0.0, 1.0)
    lower[eyes] = 0.0
    # the eyes, lids and brows: around each eye, from a quarter of the eye distance below it
    # to half of it above, not the cheeks and the nose between them and the mouth
    around = np.zeros(len(v), bool)
    for pupil in pupils.values():
        around |= (
            (np.abs(v[:, 0] - pupil[0]) < 0.45 * es)
            & (v[:, 1] > pupil[1] - 0.25 * es)
            & (v[:, 1] < pupil[1] + 0.55 * es)
            & (v[:, 2] > pupil[2] - 0.5 * es)
        )
    upper = np.union1d(np.flatnonzero(around), eyes)
    head = (
        np.asarray(seq.head_weights, dtype=np.float64)
        if seq.head_weights is not None
        else np.ones(len(v))
    )
    groups = {
        "eyeball_l": seq.eyeballs[0] if seq.eyeballs is not None else np.zeros(0, np.int64),
        "eyeball_r": seq.eyeballs[1] if seq.eyeballs is not None else np.zeros(0, np.int64),
    }
    # the cavity's points follow the sequence's vertices; every frame gets them (MeshRig)
    lips_y = seq.frames[:, mouth.lips, 1]
    reach = (float(lips_y.max()) - centre[1], centre[1] - float(lips_y.min()))
    cavity, cavity_triangles = mouth_cavity(v, seq.triangles, mouth, centre, reach)
    n = len(v)
    groups["hidden_outline"] = n + np.arange(len(cavity))  # its border is inside the head
    # it turns as the face around it does (FLAME's neck skinning): its 4 nearest vertices
    dist = np.linalg.norm(cavity[:, None] - v[None], axis=2)
    nearest = np.argpartition(dist, min(4, n) - 1, axis=1)[:, :4]
    inverse = 1.0 / np.maximum(np.take_along_axis(dist, nearest, axis=1), 1e-9)
    head = np.concatenate([head, (head[nearest] * inverse).sum(axis=1) / inverse.sum(axis=1)])
    lower = np.concatenate([lower, np.zeros(len(cavity))])
    colors = np.vstack(
        [_colors(seq, mouth.lips, pupils), np.tile(np.array(CAVITY, np.float32), (len(cavity), 1))]
    )
    return MeshFace(
        vertices=np.vstack([v, cavity]).astype(np.float32),
        triangles=np.vstack([seq.triangles, cavity_triangles + n]).astype(np.int32),
        colors=colors,
        feature_points=points,
        fp_vertices=fp_vertices,
        fapu=fapu_from_feature_points(points),
        groups=groups,
        weights={"head": head},
        name=seq.label,
        sequence=seq,
        lower_face=lower,
        upper_face=upper,
        mouth=mouth,
        notes=notes,
    )


def _mouth_vertices(v: np.ndarray, mouth: MouthPoints) -> dict[str, int]:
    """The mouth's feature points as vertices: the middles, the corners, and the vertices
    nearest halfway between (the inner and outer contours the same, as on avatars)."""
    left, right = mouth.corners
    out = {"2.2": mouth.upper, "2.3": mouth.lower, "2.4": left, "2.5": right}
    for name, a, b in (
        ("2.6", mouth.upper, left),
        ("2.7", mouth.upper, right),
        ("2.8", mouth.lower, left),
        ("2.9", mouth.lower, right),
    ):
        target = (v[a] + v[b]) / 2.0
        out[name] = int(mouth.lips[np.argmin(np.linalg.norm(v[mouth.lips] - target, axis=1))])
    for inner, outer in zip(MOUTH_FEATURE_POINTS[:8], MOUTH_FEATURE_POINTS[8:], strict=True):
        out[outer] = out[inner]
    return out


class MeshRig(Rig):
    """Poses a mesh face's frames: the head's turn and the gaze from FAPs, the rest from the
    frame's vertices (see the module's docstring)."""

    motion_tolerance = 0.0
    normal_tolerance = 0.0
    mouth_ceiling = None

    def __init__(self, face: MeshFace) -> None:  # noqa: D107 - Rig's set-up is not wanted
        self.face = face
        self.v0 = face.vertices.astype(np.float32)
        used = np.unique(face.triangles)
        self._normals = ZoneNormals(face.triangles, used, face.n_vertices)
        self._used = used
        self.n0 = self.normals(self.v0)
        self.weights = {"head": np.asarray(face.weights["head"], dtype=np.float64)}
        self.lower = face.lower_face.astype(np.float32)[:, None]
        self._moving = np.flatnonzero(face.lower_face > 0)
        self.rest_mouth_vertices = None
        centres = {
            s: face.eye_centre(s) if len(face.groups[f"eyeball_{s}"]) else face.feature_points[p]
            for s, p in (("l", "3.5"), ("r", "3.6"))
        }
        self.has_eyes = all(len(face.groups[f"eyeball_{s}"]) for s in ("l", "r"))
        self._set_pose(centres)

    def normals(self, positions: np.ndarray) -> np.ndarray:
        """Vertex normals of ``positions`` (unused vertices keep +z)."""
        out = np.zeros((len(positions), 3), np.float32)
        out[:, 2] = 1.0
        out[self._used] = self._normals(positions)
        return out

    def at_rest(self, positions: np.ndarray) -> np.ndarray:
        """``positions`` with the lower face's motion taken back to the template."""
        out = positions.copy()
        m = self._moving
        out[m] += self.lower[m] * (self.v0[m] - positions[m])
        return out

    def frame(self, positions: np.ndarray, faps: np.ndarray) -> FaceFrame:
        """The frame of vertex ``positions`` (V, 3) with the head's turn and the gaze of
        ``faps`` (68 values)."""
        f = np.asarray(faps, dtype=np.float64)
        pos = np.asarray(positions, dtype=np.float32)
        if len(pos) < len(self.v0):  # the sequence's vertices: the mouth's cavity after them
            pos = np.vstack([pos, self.v0[len(pos) :]])
        eyes = {"l": np.eye(4), "r": np.eye(4)}
        if self.has_eyes:
            for side, turns in EYE_TURNS.items():
                if any(f[t - 1] for t in turns):
                    eyes[side] = about(fap_rotation(f, turns), self.eye_centres[side])
        head = about(fap_rotation(f, HEAD_TURNS), self.pivot)
        return FaceFrame(pos, self.normals(pos), head, eyes["l"], eyes["r"])

    def deform(self, faps: np.ndarray) -> FaceFrame:
        """The template posed by ``faps`` (what a FAP face's rig gives)."""
        return self.frame(self.v0, faps)
