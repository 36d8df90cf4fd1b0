"""An avatar's names for what the ARKit table drives: its blendshapes and its head and eye bones.

The table (:data:`app.stimuli.capture.arkit.ARKIT_MAP`) drives blendshapes and, by its
rotations, the ``head``, ``leftEye`` and ``rightEye`` bones (:func:`driven`); those it drives
must all be found (:func:`require_driven`). Names are matched without regard to case.
Blendshapes: the morph target names (``jawOpen``, ``JawOpen`` or a prefixed
``blendShape1.jawOpen``, any convention of :mod:`renderer.shapenames`), then the VRM
expressions standing in for those still missing. Bones: the VRM humanoid (0.x or 1.0), or the
node names (a name ending in the bone's, as ``J_Bip_C_Head`` or ``mixamorig:Head``); eyes
named by no convention are found by :mod:`renderer.avatareyes`. A sidecar
``<file stem>.avatar.json`` beside the avatar (or the same object under ``extras.facepair`` of
the glTF root) renames either, and may place MPEG-4 feature points and vertex groups (see
docs/reference/renderer.md, "Avatars")::

    {"blendshapes": {"JawOpen": "mouth_open"}, "bones": {"head": "J_Head"},
     "feature_points": {"2.2": 812, "3.5": [0.03, 1.52, 0.09]}, "groups": {...}}
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.capture.arkit import ARKIT_MAP
from renderer.avatareyes import find_eyes
from renderer.gltfio import GltfScene
from renderer.lips import MOUTH_SHAPES
from renderer.shapenames import VRM_PRESETS, arkit_spelling, canonical

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


def _canonical(name: str) -> str:
    """A bone name without its prefix up to the last dot, its case and its punctuation."""
    return re.sub(r"[^a-z0-9]", "", name.rsplit(".", 1)[-1].lower())


def read_sidecar(path: Path, scene: GltfScene) -> dict[str, Any]:
    """The avatar's mapping: ``extras.facepair`` of the glTF root, updated by the sidecar
    ``<file stem>.avatar.json`` beside it (module docstring)."""
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


def find_shapes(
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


def subtree(parents: np.ndarray, root: int) -> np.ndarray:
    """Whether each node is ``root`` or below it in the hierarchy of ``parents``."""
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
        inside = subtree(scene.parents, node)[main]
        holds[node] = int(inside.sum())
        if holds[node]:
            x[node] = float(scene.vertices[inside, 0].mean())
    return holds, depth, x


def rig_nodes(scene: GltfScene, spec: dict[str, Any]) -> tuple[dict[str, int | None], str]:
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


def eye_error(scene: GltfScene, path: Path) -> InputError:
    """The error of an avatar whose eyes cannot be found: the nodes that name an eye, and
    how to name the eye nodes in the sidecar."""
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


def skin_share(scene: GltfScene, node: int) -> np.ndarray:
    """The share of each vertex's skin weight held by ``node`` and the nodes below it."""
    total = np.maximum(scene.influence_weights.sum(axis=1), 1e-12)
    inside = subtree(scene.parents, node)[scene.influence_nodes]
    return (scene.influence_weights * inside).sum(axis=1) / total


def require_driven(
    path: Path,
    shapes: dict[str, tuple[np.ndarray, np.ndarray]],
    drives: dict[str, tuple[str, ...]],
    renamed: dict[str, Any],
    head_missing: bool,
) -> None:
    """An :class:`~app.errors.InputError` naming every blendshape the ARKit table drives
    that the avatar lacks (unless the sidecar declares it absent with null), with the FAPs
    it would have driven, and the head bone where ``head_missing``."""
    shapes_needed, _bones = driven()
    absent = {canonical(k) for k, v in renamed.items() if v is None}
    covered = set(shapes) | {s for d in drives.values() for s in d}
    lacking = [
        f"blendshape {arkit_spelling(k)} (FAP {', '.join(map(str, faps))})"
        for k, faps in shapes_needed.items()
        if k not in covered and canonical(k) not in absent
    ]
    if head_missing:
        lacking.append("bone head (FAP 48, 49, 50)")
    if lacking:
        raise InputError(
            "missing " + "; ".join(lacking) + " (rename them in "
            f"{path.stem}.avatar.json, or declare them absent with null; see "
            "docs/reference/renderer.md)",
            path=path,
        )
