"""glTF 2.0 / VRM avatars with ARKit blendshapes, driven by FAP tracks.

A FAP frame becomes ARKit weights and head and eye rotations by the one table facepair has for
ARKit (:func:`app.stimuli.capture.arkit.arkit_weights`, the inverse of the Live Link Face
import); the weights (clipped to ARKit's 0..1) mix the avatar's morph targets, and the
rotations turn its ``head``, ``leftEye`` and ``rightEye`` bones, rigidly and in the face's own
frame: the head about the head bone (vertices skinned partly to the head subtree follow in
proportion, as a neck does), the eyes about the eye bones. The blendshapes and bones the
table drives (:func:`renderer.avatarnames.driven`) must all be present; a missing one is an
:class:`~app.errors.InputError` naming it and the FAPs it would have driven.

How they are found by name, in any convention, and renamed by a sidecar
``<file stem>.avatar.json`` that may also place MPEG-4 feature points and vertex groups, is
:mod:`renderer.avatarnames` (see docs/reference/renderer.md, "Avatars").

Without feature points the renderer places its own: the eyes at the eye bones, the mouth from
the vertices ``JawOpen`` moves (:func:`mouth_points`); the camera and the mouth mosaic follow
them as on the built-in head.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.capture.arkit import ARKIT_MAP, BLENDSHAPES, arkit_weights
from renderer.avatareyes import eye_geometry
from renderer.avatarmouth import head_region, mouth_points, opening_shape
from renderer.avatarnames import (
    driven,
    eye_error,
    find_shapes,
    read_sidecar,
    require_driven,
    rig_nodes,
    skin_share,
)
from renderer.deform import EYE_TURNS, HEAD_TURNS, Rig, about, fap_rotation
from renderer.face import MOUTH_FEATURE_POINTS, Face, fapu_from_feature_points, vertex_normals
from renderer.gltfio import GltfScene, read_gltf
from renderer.lips import MOUTH_SHAPES, mouth_faps, mouth_weights
from renderer.skin import ZoneNormals, one_ring

#: A normal delta smaller than this (per component) is rounding, not a turn of the surface
#: (the file's deltas carry noise of 1e-7; a turn of 0.01 degree is 1.7e-4).
NORMAL_CHANGE = 1e-5
#: Avatar file suffixes ``RenderSettings.face`` accepts.
AVATAR_SUFFIXES: tuple[str, ...] = (".glb", ".gltf", ".vrm")


def shape_faps(name: str) -> np.ndarray:
    """The 68 FAP values blendshape ``name`` stands for at weight 1 (the ARKit table, or the
    lips' table of :mod:`renderer.lips` for a mouth shape)."""
    if name in MOUTH_SHAPES:
        return mouth_faps(name)
    column = {n: np.array([1.0 if n == name else 0.0]) for n in BLENDSHAPES}
    out = np.zeros(68)
    for fap, values in ARKIT_MAP.apply(column.__getitem__, set(BLENDSHAPES)).items():
        out[fap - 1] = values[0]
    return out


@dataclass(eq=False)
class AvatarFace(Face):
    """A :class:`Face` read from a glTF / VRM avatar: morph targets and bone pivots besides.

    targets : shape -> (dpos, dnormal) float32 (n, 3) at weight 1, keyed by the ARKit table's
        name it stands for (or a VRM preset's name standing for several).
    drives : shape -> the ARKit table names whose mean weight drives it (absent: its own key).
    eye_pivots : ``"l"`` / ``"r"`` -> eye bone position.
    """

    targets: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    drives: dict[str, tuple[str, ...]] = field(default_factory=dict)
    eye_pivots: dict[str, np.ndarray] = field(default_factory=dict)
    file_normals: np.ndarray | None = None
    #: how the eyes were found (:mod:`renderer.avatareyes`), for what a command reports
    eyes_found: str = ""
    #: what was inferred about the avatar, one line each (the eyes, a shape standing in)
    notes: list[str] = field(default_factory=list)

    def normals(self) -> np.ndarray:
        """The file's vertex normals (they stay smooth across UV seams), else computed."""
        if self.file_normals is not None:
            return self.file_normals.astype(np.float32)
        return vertex_normals(self.vertices, self.triangles)

    def content_hash(self) -> str:
        import hashlib

        h = hashlib.sha256(super().content_hash().encode())
        for name in sorted(self.targets):
            h.update(name.encode())
            for arr in self.targets[name]:
                h.update(np.ascontiguousarray(arr).tobytes())
        for name in sorted(self.drives):
            h.update(("drives " + name + ":" + ",".join(self.drives[name])).encode())
        for side in sorted(self.eye_pivots):
            h.update(np.asarray(self.eye_pivots[side], dtype=np.float64).tobytes())
        return h.hexdigest()


class AvatarRig(Rig):
    """FAP frames -> posed avatar: ARKit weights on the morph targets, rotations on the bones.

    Shares :meth:`Rig.posed` (eyes, then the head blended by the ``head`` weight) and
    :meth:`Rig.world_points`; the mouth at rest is the avatar deformed again without the
    mouth FAPs.
    """

    def __init__(self, face: AvatarFace) -> None:  # noqa: D107 - Rig's set-up is not wanted
        self.face = face
        self.v0 = face.vertices.astype(np.float32)
        self.n0 = face.normals()
        self.weights = {"head": np.asarray(face.weights["head"], dtype=np.float64)}
        self.names = list(face.targets)
        self.drives = face.drives
        dpos = np.stack([face.targets[k][0] for k in self.names]).astype(np.float32)
        dnrm = np.stack([face.targets[k][1] for k in self.names]).astype(np.float32)
        self.zone = np.flatnonzero((np.abs(dpos) > 0).any(axis=(0, 2)))
        self.dpos, self.dnrm = dpos[:, self.zone], dnrm[:, self.zone]
        # normals from the targets where the file gives them, else recomputed on the zone
        self.zone_normals = (
            None
            if np.abs(dnrm).any()
            else ZoneNormals(
                face.triangles,
                one_ring(face.triangles, self.zone, face.n_vertices),
                face.n_vertices,
            )
        )
        # the mosaic's reach (renderer.mouthregion): motion of a sculpted shape smaller than a
        # five-hundredth of the eye distance (a fifth of a pixel at the default size) or above
        # the middle of the nose is no mouth motion; the face is drawn with its mouth at rest
        fp = face.feature_points
        eyes_y = (fp["3.5"][1] + fp["3.6"][1]) / 2.0
        mouth_y = (fp["2.2"][1] + fp["2.3"][1]) / 2.0
        self.motion_tolerance = 0.002 * float(np.linalg.norm(fp["3.5"] - fp["3.6"]))
        self.normal_tolerance = 0.01
        self.mouth_ceiling = float(eyes_y - 0.45 * (eyes_y - mouth_y))
        if self.zone_normals is not None:
            # the file's normals (smooth across UV seams) turn by what the motion changes in
            # the recomputed ones; where nothing moves they stay the file's, bit for bit
            self.rest_zone_normals = self.zone_normals(self.v0)
        self._set_pose({s: face.eye_pivots.get(s, face.eye_centre(s)) for s in ("l", "r")})
        self.rest_mouth_vertices = None

    def deform(self, faps: np.ndarray):
        """Mix the morph targets and set the bone rotations for one frame of 68 FAPs."""
        from renderer.deform import FaceFrame

        f = np.asarray(faps, dtype=np.float64)
        w = {**arkit_weights(f), **mouth_weights(f)}
        drives = self.drives
        coeff = np.clip(
            [np.mean([float(w[s]) for s in drives.get(k, (k,))]) for k in self.names], 0.0, 1.0
        ).astype(np.float32)
        pos, nrm = self.v0.copy(), self.n0.copy()
        on = np.flatnonzero(coeff)
        if len(on):
            z = self.zone
            pos[z] += np.tensordot(coeff[on], self.dpos[on], axes=1)
            if self.zone_normals is None:
                z, change = z, np.tensordot(coeff[on], self.dnrm[on], axes=1)
            else:
                z = self.zone_normals.zone
                change = self.zone_normals(pos) - self.rest_zone_normals
            # only normals that turn are renormalised: rounding elsewhere would read as motion
            # of the whole face (renderer.mouthregion bounds what the mouth changes)
            turned = np.abs(change).max(axis=1) > NORMAL_CHANGE
            n = self.n0[z[turned]] + change[turned]
            nrm[z[turned]] = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
        eyes = {
            side: about(fap_rotation(f, turns), self.eye_centres[side])
            for side, turns in EYE_TURNS.items()
        }
        head = fap_rotation(f, HEAD_TURNS)
        return FaceFrame(pos, nrm, about(head, self.pivot), eyes["l"], eyes["r"])


def load_avatar(path: str | Path) -> AvatarFace:
    """Read a glTF / VRM avatar as an :class:`AvatarFace` (see the module docstring)."""
    path = Path(path)
    scene = read_gltf(path)
    spec = read_sidecar(path, scene)
    shapes_needed, _bones = driven()
    renamed = spec.get("blendshapes", {})
    shapes, drives = find_shapes(scene, list(shapes_needed), renamed)
    nodes, eyes_how = rig_nodes(scene, spec)
    unskinned = scene.skinned is None or not scene.skinned.any()
    require_driven(path, shapes, drives, renamed, nodes["head"] is None and not unskinned)
    eye_nodes = (nodes["leftEye"], nodes["rightEye"])
    if any(i is None or not 0 <= i < len(scene.parents) for i in eye_nodes):
        raise eye_error(scene, path)
    targets = {k: (dp.astype(np.float32), dn.astype(np.float32)) for k, (dp, dn) in shapes.items()}
    v = scene.vertices
    groups, pivots, pupils = _eyes(scene, *eye_nodes)  # type: ignore[arg-type]
    # a head made of unskinned meshes (Face Cap's) turns as one, its eyes and teeth too
    head = np.ones(len(v)) if unskinned else skin_share(scene, nodes["head"])  # type: ignore[arg-type]
    for name, value in spec.get("groups", {}).items():
        groups[name] = np.asarray(value, dtype=np.int64)
    eyes = (pupils["l"] + pupils["r"]) / 2.0
    es = float(np.linalg.norm(pupils["l"] - pupils["r"]))
    neck = (
        scene.world[nodes["head"], :3, 3].copy()  # type: ignore[index]
        if nodes["head"] is not None
        else eyes + np.array([0.0, -0.87, -1.61]) * es  # the built-in head's proportions
    )
    points: dict[str, np.ndarray] = {"3.5": pupils["l"], "3.6": pupils["r"], "7.1": neck}
    fp_vertices = _given_points(spec, v, points, path)
    notes = [f"eyes found {eyes_how}"]
    notes += _mouth(scene, targets, pupils, (points, fp_vertices), path)
    # one texture for the whole avatar is sampled per pixel, as the built-in head's is
    colors = scene.colors if scene.untextured_colors is None else scene.untextured_colors
    return AvatarFace(
        vertices=v.astype(np.float32),
        triangles=scene.triangles.astype(np.int32),
        colors=colors.astype(np.float32),
        feature_points=points,
        fp_vertices=fp_vertices,
        fapu=_fapu(points),
        groups=groups,
        weights={"head": head},
        name=path.stem,
        targets=targets,
        drives=drives,
        eye_pivots=pivots,
        file_normals=scene.normals,
        uvs=scene.uvs,
        texture=scene.texture,
        eyes_found=eyes_how,
        notes=notes,
    )


def _eyes(
    scene: GltfScene, left: int, right: int
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The eyeball groups (the vertices skinned to each eye bone by more than half), the
    eyes' centres of rotation and their pupils: at the eye bones, or at the eyeballs where a
    bone sits away from its eyeball (:func:`renderer.avatareyes.eye_geometry`)."""
    v = scene.vertices
    bones = {"l": left, "r": right}
    groups = {f"eyeball_{s}": np.flatnonzero(skin_share(scene, b) > 0.5) for s, b in bones.items()}
    pivots = {s: scene.world[b, :3, 3].copy() for s, b in bones.items()}
    pupils = dict(pivots)
    balls = {s: v[groups[f"eyeball_{s}"]] for s in ("l", "r")}
    middles = {s: (b.min(axis=0) + b.max(axis=0)) / 2.0 for s, b in balls.items() if len(b)}
    inter_eye = float(
        np.linalg.norm(middles["l"] - middles["r"])
        if len(middles) == 2
        else np.linalg.norm(pivots["l"] - pivots["r"])
    )
    for s in ("l", "r"):
        placed = eye_geometry(balls[s], pivots[s], max(inter_eye, 1e-9))
        if placed is not None:  # a bone away from its eyeball (VRoid's): the eyeball decides
            pupils[s], pivots[s] = placed
    return groups, pivots, pupils


def _given_points(
    spec: dict[str, Any], v: np.ndarray, points: dict[str, np.ndarray], path: Path
) -> dict[str, int]:
    """The sidecar's feature points added to ``points``; returns those that are vertices."""
    fp_vertices: dict[str, int] = {}
    for name, value in spec.get("feature_points", {}).items():
        if isinstance(value, int) and 0 <= value < len(v):
            fp_vertices[name] = value
            points[name] = v[value].copy()
        elif isinstance(value, list) and len(value) == 3:
            points[name] = np.array(value, dtype=np.float64)
        else:
            raise InputError(
                "expected a vertex index or [x, y, z]", path=path, field=f"feature_points.{name}"
            )
    return fp_vertices


def _mouth(
    scene: GltfScene,
    targets: dict[str, tuple[np.ndarray, np.ndarray]],
    pupils: dict[str, np.ndarray],
    found: tuple[dict[str, np.ndarray], dict[str, int]],
    path: Path,
) -> list[str]:
    """The mouth found by the shape that opens it (:mod:`renderer.avatarmouth`): its feature
    points where the sidecar gives none, added to ``found`` (the feature points and those
    that are vertices), and that shape as ``JawOpen`` where the avatar's moves nothing;
    returns what was inferred."""
    v = scene.vertices
    points, fp_vertices = found
    notes = []
    pool = {k: dp for k, (dp, _) in scene.expressions.items()}
    pool.update({k: dp for k, (dp, _) in scene.targets.items()})
    opening = opening_shape(pool, head_region(v, pupils["l"], pupils["r"]))
    jaw = targets.get("JawOpen")
    if opening is not None and jaw is not None and not np.abs(jaw[0]).any():
        # VRoid's exports carry an empty jawOpen: FAP 3 opens the jaw by the shape that does
        shape = scene.targets.get(opening[0]) or scene.expressions.get(opening[0])
        if shape is not None:
            targets["JawOpen"] = (shape[0].astype(np.float32), shape[1].astype(np.float32))
            notes.append(f"jawOpen moves nothing: {opening[0]} opens the jaw instead")
    if not all(k in fp_vertices for k in MOUTH_FEATURE_POINTS):
        if opening is None:
            raise InputError(
                "no mouth shape (jawOpen, aa, mouthOpen, mouth...) moves the face below the "
                "eyes: the mouth cannot be found (give its feature points 2.2-2.9 in "
                f"{path.stem}.avatar.json)",
                path=path,
            )
        fp_vertices.update(mouth_points(v, opening[1], pupils["l"], pupils["r"]))
        points.update({k: v[fp_vertices[k]].copy() for k in MOUTH_FEATURE_POINTS})
    return notes


def _fapu(points: dict[str, np.ndarray]) -> dict[str, float]:
    """FAPU of an avatar: measured where its feature points allow, else in proportion to
    the pupil distance (IRISD0 and ENS0 are not used on avatars)."""
    p = dict(points)
    es = float(np.linalg.norm(p["3.5"] - p["3.6"]))
    eyes = (p["3.5"] + p["3.6"]) / 2.0
    mouth = (p["2.2"] + p["2.3"]) / 2.0
    p.setdefault("3.1", p["3.5"] + [0.0, 0.1 * es, 0.0])
    p.setdefault("3.3", p["3.5"] - [0.0, 0.1 * es, 0.0])
    p.setdefault("9.15", eyes + 0.62 * (mouth - eyes))
    return fapu_from_feature_points(p)
