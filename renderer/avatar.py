"""glTF 2.0 / VRM avatars with ARKit blendshapes, driven by FAP tracks.

A FAP frame becomes ARKit weights and head and eye rotations by the one table facepair has for
ARKit (:func:`app.stimuli.capture.arkit.arkit_weights`, the inverse of the Live Link Face
import); the weights (clipped to ARKit's 0..1) mix the avatar's morph targets, and the
rotations turn its ``head``, ``leftEye`` and ``rightEye`` bones, rigidly and in the face's own
frame: the head about the head bone (vertices skinned partly to the head subtree follow in
proportion, as a neck does), the eyes about the eye bones. The blendshapes and bones the
table drives (:func:`driven`) must all be present; a missing one is an
:class:`~app.errors.InputError` naming it and the FAPs it would have driven.

Names are matched without regard to case. Blendshapes: the morph target names (``jawOpen``,
``JawOpen`` or a prefixed ``blendShape1.jawOpen``). Bones: the VRM humanoid (0.x or 1.0), or
the node names. A sidecar ``<file stem>.avatar.json`` beside the avatar (or the same object
under ``extras.facepair`` of the glTF root) renames either and may place MPEG-4 feature
points (see docs/reference/renderer.md, "Avatars")::

    {"blendshapes": {"JawOpen": "mouth_open"}, "bones": {"head": "J_Head"},
     "feature_points": {"2.2": 812, "3.5": [0.03, 1.52, 0.09]}, "groups": {...}}

Without feature points the renderer places its own: the eyes at the eye bones, the mouth from
the vertices ``JawOpen`` moves (:func:`mouth_points`); the camera and the mouth mosaic follow
them as on the built-in head.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.capture.arkit import ARKIT_MAP, BLENDSHAPES, arkit_weights
from renderer.deform import EYE_TURNS, HEAD_TURNS, Rig, about, fap_rotation
from renderer.face import MOUTH_FEATURE_POINTS, Face, fapu_from_feature_points, vertex_normals
from renderer.gltfio import GltfScene, read_gltf
from renderer.lips import MOUTH_SHAPES, mouth_faps, mouth_weights
from renderer.shapenames import VRM_PRESETS, arkit_spelling, canonical
from renderer.skin import ZoneNormals, one_ring

#: Avatar file suffixes ``RenderSettings.face`` accepts.
AVATAR_SUFFIXES: tuple[str, ...] = (".glb", ".gltf", ".vrm")
#: The bones the rotations of the ARKit table turn (VRM humanoid names).
BONE_OF_ROTATION = {
    "HeadPitch": "head",
    "HeadYaw": "head",
    "HeadRoll": "head",
    "LeftEyeYaw": "leftEye",
    "LeftEyePitch": "leftEye",
    "RightEyeYaw": "rightEye",
    "RightEyePitch": "rightEye",
}


def driven() -> tuple[dict[str, list[int]], dict[str, list[int]]]:
    """The blendshapes and the bones the ARKit table drives, each with the FAPs it drives."""
    shapes: dict[str, list[int]] = {}
    bones: dict[str, list[int]] = {}
    for fap in ARKIT_MAP.faps:
        for name in ARKIT_MAP.columns_of(fap):
            store, key = (
                (bones, BONE_OF_ROTATION[name]) if name in BONE_OF_ROTATION else (shapes, name)
            )
            if fap not in store.setdefault(key, []):
                store[key].append(fap)
    return shapes, bones


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


def _canonical(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", name.rsplit(".", 1)[-1].lower())


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
                n = self.n0[z] + np.tensordot(coeff[on], self.dnrm[on], axes=1)
                nrm[z] = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
            else:
                nrm[self.zone_normals.zone] = self.zone_normals(pos)
        eyes = {
            side: about(fap_rotation(f, turns), self.eye_centres[side])
            for side, turns in EYE_TURNS.items()
        }
        head = fap_rotation(f, HEAD_TURNS)
        return FaceFrame(pos, nrm, about(head, self.pivot), eyes["l"], eyes["r"])


def mouth_points(
    vertices: np.ndarray, jaw: np.ndarray, eye_l: np.ndarray, eye_r: np.ndarray
) -> dict[str, int]:
    """Mouth feature points (2.2-2.9, 8.1-8.8) of an avatar as vertex indices, from the
    displacement ``jaw`` (n, 3) of its ``JawOpen`` shape and its eye positions.

    The lower lip's middle (2.3, 8.2) is the highest vertex near the midline that the jaw
    moves by at least half its largest displacement, among the front-most ones (the lower
    teeth and tongue move too, behind it); the upper lip's (2.2, 8.1) the nearest vertex above
    it, not behind it, that the jaw barely moves. The corners lie 0.4 eye distances (an
    adult's mouth width is about 0.8 of the pupil distance) to either side, set back a little;
    the points between are halfway. Each is the nearest vertex to where it is expected.
    """
    v = np.asarray(vertices, dtype=np.float64)
    disp = np.linalg.norm(jaw, axis=1)
    es = float(np.linalg.norm(eye_l - eye_r))
    mid = (eye_l + eye_r) / 2.0
    near_mid = (np.abs(v[:, 0] - mid[0]) < 0.15 * es) & (v[:, 1] < mid[1] - 0.3 * es)
    moved = near_mid & (disp >= 0.5 * disp.max())
    if not moved.any():
        raise InputError(
            "JawOpen moves no vertex below the eyes near the midline: the mouth "
            "cannot be found (give its feature points in the sidecar)",
            field="feature_points",
        )
    front = moved & (v[:, 2] > v[moved, 2].max() - 0.25 * es)
    central = front & (np.abs(v[:, 0] - mid[0]) < 0.05 * es)
    front = central if central.any() else front
    lower = int(np.flatnonzero(front)[np.argmax(v[front, 1])])
    above = (
        near_mid
        & (disp < 0.15 * disp.max())
        & (v[:, 1] >= v[lower, 1])
        & (v[:, 1] < v[lower, 1] + 0.5 * es)
        & (v[:, 2] > v[lower, 2] - 0.1 * es)
    )
    upper = (
        int(np.flatnonzero(above)[np.argmin(np.linalg.norm(v[above] - v[lower], axis=1))])
        if above.any()
        else _nearest(v, v[lower] + [0.0, 0.05 * es, 0.0])
    )
    centre = (v[upper] + v[lower]) / 2.0
    centre[0] = mid[0]
    corner = {s: _nearest(v, centre + [s * 0.4 * es, 0.0, -0.12 * es]) for s in (1, -1)}
    out = {"2.2": upper, "2.3": lower, "2.4": corner[1], "2.5": corner[-1]}
    for name, a, b in (
        ("2.6", upper, corner[1]),
        ("2.7", upper, corner[-1]),
        ("2.8", lower, corner[1]),
        ("2.9", lower, corner[-1]),
    ):
        out[name] = _nearest(v, (v[a] + v[b]) / 2.0)
    for inner, outer in zip(MOUTH_FEATURE_POINTS[:8], MOUTH_FEATURE_POINTS[8:], strict=True):
        out[outer] = out[inner]
    return out


def _nearest(v: np.ndarray, point: np.ndarray) -> int:
    return int(np.argmin(np.linalg.norm(v - point, axis=1)))


def _sidecar(path: Path, scene: GltfScene) -> dict[str, Any]:
    spec = dict(scene.extras.get("facepair") or {})
    side = path.with_name(path.stem + ".avatar.json")
    if side.is_file():
        try:
            extra = json.loads(side.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError(f"not valid JSON: {exc}", path=side) from None
        if not isinstance(extra, dict):
            raise InputError("expected a JSON object", path=side)
        spec.update(extra)
    for key in ("blendshapes", "bones", "feature_points", "groups"):
        if not isinstance(spec.get(key, {}), dict):
            raise InputError("expected an object", path=side, field=key)
    return spec


def _find_shape(wanted: str, names: list[str], renamed: dict[str, Any]) -> int | None:
    """Index of blendshape ``wanted`` in ``names``: the sidecar's name for it (keyed in any
    convention), else the same shape in any naming convention (:func:`canonical`)."""
    target = {canonical(k): v for k, v in renamed.items()}.get(canonical(wanted))
    if isinstance(target, str):
        return names.index(target) if target in names else None
    keys = [canonical(n) for n in names]
    key = canonical(wanted)
    return keys.index(key) if key in keys else None


def _shapes(
    scene: GltfScene, needed: list[str], renamed: dict[str, Any]
) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], dict[str, tuple[str, ...]]]:
    """The avatar's shape for each ARKit name it has (the table's and the mouth's), by name in
    any convention, then by VRM preset (:data:`VRM_PRESETS`) for those still missing."""
    pool = dict(scene.targets)
    pool.update({k: v for k, v in scene.expressions.items() if k not in pool})
    names = list(pool)
    shapes: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    drives: dict[str, tuple[str, ...]] = {}
    for k in dict.fromkeys([*needed, *MOUTH_SHAPES]):
        i = _find_shape(k, names, renamed)
        if i is not None:
            shapes[k] = pool[names[i]]
    covered = set(shapes)
    presets = {canonical(n): n for n in scene.expressions}
    for key, stands in VRM_PRESETS.items():
        if key in presets and not covered & set(stands):
            slot = stands[0] if len(stands) == 1 else presets[key]
            shapes[slot] = scene.expressions[presets[key]]
            drives[slot] = stands
            covered |= set(stands)
    return shapes, drives


def _find(wanted: str, names: list[str], renamed: dict[str, Any]) -> int | None:
    """Index of ``wanted`` in ``names``: the sidecar's name for it, else a case- and
    punctuation-blind match, else a name ending in it (``J_Bip_C_Head``, ``mixamorig:Head``)."""
    target = renamed.get(wanted)
    keys = [_canonical(n) for n in names]
    if isinstance(target, str):
        return names.index(target) if target in names else None
    key = _canonical(wanted)
    if key in keys:
        return keys.index(key)
    ends = [i for i, k in enumerate(keys) if k.endswith(key)]
    return ends[0] if len(ends) == 1 else None


def _subtree(parents: np.ndarray, root: int) -> np.ndarray:
    inside = np.zeros(len(parents), bool)
    for i in range(len(parents)):
        j = i
        while j >= 0 and not inside[j] and j != root:
            j = parents[j]
        inside[i] = j == root or (j >= 0 and inside[j])
    return inside


def load_avatar(path: str | Path) -> AvatarFace:
    """Read a glTF / VRM avatar as an :class:`AvatarFace` (see the module docstring)."""
    path = Path(path)
    scene = read_gltf(path)
    spec = _sidecar(path, scene)
    shapes_needed, bones_needed = driven()
    shapes, drives = _shapes(scene, list(shapes_needed), spec.get("blendshapes", {}))
    covered = set(shapes) | {s for d in drives.values() for s in d}
    nodes = {
        k: (
            spec["bones"][k]
            if isinstance(spec.get("bones", {}).get(k), int)
            else scene.humanoid.get(k, _find(k, scene.node_names, spec.get("bones", {})))
        )
        for k in bones_needed
    }
    lacking = [
        f"blendshape {arkit_spelling(k)} (FAP {', '.join(map(str, faps))})"
        for k, faps in shapes_needed.items()
        if k not in covered
    ]
    lacking += [
        f"bone {k} (FAP {', '.join(map(str, bones_needed[k]))})"
        for k, i in nodes.items()
        if i is None or not 0 <= i < len(scene.parents)
    ]
    if lacking:
        raise InputError(
            "missing " + "; ".join(lacking) + " (rename them in "
            f"{path.stem}.avatar.json, see docs/reference/renderer.md)",
            path=path,
        )
    targets = {k: (dp.astype(np.float32), dn.astype(np.float32)) for k, (dp, dn) in shapes.items()}
    total = np.maximum(scene.influence_weights.sum(axis=1), 1e-12)

    def share(node: int) -> np.ndarray:
        inside = _subtree(scene.parents, node)[scene.influence_nodes]
        return (scene.influence_weights * inside).sum(axis=1) / total

    head = share(nodes["head"])  # type: ignore[arg-type]
    groups = {
        f"eyeball_{s}": np.flatnonzero(share(nodes[b]) > 0.5)  # type: ignore[arg-type]
        for s, b in (("l", "leftEye"), ("r", "rightEye"))
    }
    for name, value in spec.get("groups", {}).items():
        groups[name] = np.asarray(value, dtype=np.int64)
    pivots = {
        s: scene.world[nodes[b], :3, 3].copy()  # type: ignore[index]
        for s, b in (("l", "leftEye"), ("r", "rightEye"))
    }
    v = scene.vertices
    fp_vertices: dict[str, int] = {}
    points: dict[str, np.ndarray] = {
        "3.5": pivots["l"],
        "3.6": pivots["r"],
        "7.1": scene.world[nodes["head"], :3, 3].copy(),
    }  # type: ignore[index]
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
    if not all(k in fp_vertices for k in MOUTH_FEATURE_POINTS):
        fp_vertices.update(mouth_points(v, targets["JawOpen"][0], pivots["l"], pivots["r"]))
        points.update({k: v[fp_vertices[k]].copy() for k in MOUTH_FEATURE_POINTS})
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
    )


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
