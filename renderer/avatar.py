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
from renderer.avatareyes import eye_geometry, find_eyes
from renderer.avatarmouth import head_region, mouth_points, opening_shape
from renderer.deform import EYE_TURNS, HEAD_TURNS, Rig, about, fap_rotation
from renderer.face import MOUTH_FEATURE_POINTS, Face, fapu_from_feature_points, vertex_normals
from renderer.gltfio import GltfScene, read_gltf
from renderer.lips import MOUTH_SHAPES, mouth_faps, mouth_weights
from renderer.shapenames import VRM_PRESETS, arkit_spelling, canonical
from renderer.skin import ZoneNormals, one_ring

#: A normal delta smaller than this (per component) is rounding, not a turn of the surface
#: (the file's deltas carry noise of 1e-7; a turn of 0.01 degree is 1.7e-4).
NORMAL_CHANGE = 1e-5
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


def _node_facts(scene: GltfScene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per node: how many vertices it moves (skinned to it by more than half, or in a mesh of
    its subtree), its depth in the hierarchy, and the x of what it holds (else its own)."""
    k = len(scene.parents)
    depth = np.zeros(k, int)
    for i in range(k):
        j = scene.parents[i]
        while j >= 0 and depth[i] <= k:
            depth[i] += 1
            j = scene.parents[j]
    main = scene.influence_nodes[np.arange(len(scene.vertices)), scene.influence_weights.argmax(1)]
    holds = np.zeros(k, int)
    x = scene.world[:, 0, 3].copy()
    for node in range(k):
        inside = _subtree(scene.parents, node)[main]
        holds[node] = int(inside.sum())
        if holds[node]:
            x[node] = float(scene.vertices[inside, 0].mean())
    return holds, depth, x


def _rig_nodes(scene: GltfScene, spec: dict[str, Any]) -> tuple[dict[str, int | None], str]:
    """The head and eye nodes (None where absent) and how the eyes were found: the sidecar's
    and the VRM humanoid's names first, then the naming conventions of
    :mod:`renderer.avatareyes` with the sides taken from the geometry."""
    bones = spec.get("bones", {})

    def named(k: str) -> int | None:
        if isinstance(bones.get(k), int):
            return int(bones[k])
        if isinstance(bones.get(k), str) or k not in scene.humanoid:
            return _find(k, scene.node_names, bones) if k == "head" or k in bones else None
        return scene.humanoid[k]

    nodes: dict[str, int | None] = {k: named(k) for k in ("head", "leftEye", "rightEye")}
    how = "as named in the sidecar or the VRM humanoid"
    if nodes["leftEye"] is None or nodes["rightEye"] is None:
        labels = [f"{n} {m}" for n, m in zip(scene.node_names, scene.mesh_names, strict=True)]
        found = find_eyes(labels, *_node_facts(scene))
        if found is not None:
            nodes["leftEye"], nodes["rightEye"] = found.nodes["l"], found.nodes["r"]
            how = found.how
    return nodes, how


def _eye_error(scene: GltfScene, path: Path) -> InputError:
    seen = [
        n
        for n, m in zip(scene.node_names, scene.mesh_names, strict=True)
        if "eye" in f"{n}{m}".lower()
    ]
    found = f"nodes naming an eye: {', '.join(seen[:8])}" if seen else "no node names an eye"
    return InputError(
        f"the eyes cannot be found ({found}); name the eye nodes in {path.stem}.avatar.json "
        '({"bones": {"leftEye": ..., "rightEye": ...}}, the character\'s own left and right; '
        "see docs/reference/renderer.md, Avatars)",
        path=path,
    )


def load_avatar(path: str | Path) -> AvatarFace:
    """Read a glTF / VRM avatar as an :class:`AvatarFace` (see the module docstring)."""
    path = Path(path)
    scene = read_gltf(path)
    spec = _sidecar(path, scene)
    shapes_needed, _bones = driven()
    renamed = spec.get("blendshapes", {})
    shapes, drives = _shapes(scene, list(shapes_needed), renamed)
    absent = {canonical(k) for k, v in renamed.items() if v is None}
    covered = set(shapes) | {s for d in drives.values() for s in d}
    lacking = [
        f"blendshape {arkit_spelling(k)} (FAP {', '.join(map(str, faps))})"
        for k, faps in shapes_needed.items()
        if k not in covered and canonical(k) not in absent
    ]
    nodes, eyes_how = _rig_nodes(scene, spec)
    unskinned = scene.skinned is None or not scene.skinned.any()
    if nodes["head"] is None and not unskinned:
        lacking.append("bone head (FAP 48, 49, 50)")
    if lacking:
        raise InputError(
            "missing " + "; ".join(lacking) + " (rename them in "
            f"{path.stem}.avatar.json, or declare them absent with null; see "
            "docs/reference/renderer.md)",
            path=path,
        )
    eye_nodes = (nodes["leftEye"], nodes["rightEye"])
    if any(i is None or not 0 <= i < len(scene.parents) for i in eye_nodes):
        raise _eye_error(scene, path)
    targets = {k: (dp.astype(np.float32), dn.astype(np.float32)) for k, (dp, dn) in shapes.items()}
    total = np.maximum(scene.influence_weights.sum(axis=1), 1e-12)

    def share(node: int) -> np.ndarray:
        inside = _subtree(scene.parents, node)[scene.influence_nodes]
        return (scene.influence_weights * inside).sum(axis=1) / total

    v = scene.vertices
    groups = {
        f"eyeball_{s}": np.flatnonzero(share(nodes[b]) > 0.5)  # type: ignore[arg-type]
        for s, b in (("l", "leftEye"), ("r", "rightEye"))
    }
    pivots = {
        s: scene.world[nodes[b], :3, 3].copy()  # type: ignore[index]
        for s, b in (("l", "leftEye"), ("r", "rightEye"))
    }
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
    # a head made of unskinned meshes (Face Cap's) turns as one, its eyes and teeth too
    head = np.ones(len(v)) if unskinned else share(nodes["head"])  # type: ignore[arg-type]
    for name, value in spec.get("groups", {}).items():
        groups[name] = np.asarray(value, dtype=np.int64)
    eyes = (pupils["l"] + pupils["r"]) / 2.0
    es = float(np.linalg.norm(pupils["l"] - pupils["r"]))
    neck = (
        scene.world[nodes["head"], :3, 3].copy()  # type: ignore[index]
        if nodes["head"] is not None
        else eyes + np.array([0.0, -0.87, -1.61]) * es  # the built-in head's proportions
    )
    fp_vertices: dict[str, int] = {}
    points: dict[str, np.ndarray] = {"3.5": pupils["l"], "3.6": pupils["r"], "7.1": neck}
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
    notes = [f"eyes found {eyes_how}"]
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
