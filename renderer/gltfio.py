"""glTF 2.0 / VRM files in: the geometry, morph targets, skin and bones of an avatar.

Reading (:func:`read_gltf`) flattens the default scene into one vertex list: every primitive of
every mesh node, triangles only, in node order. Positions of unskinned meshes are taken to the
scene's space by their node's world transform; skinned meshes are taken as bound (their
vertices already in the skeleton's space, the usual ``inverseBindMatrices`` = inverse joint
world transforms). Morph targets are matched across primitives by name (``mesh.extras
.targetNames``, the convention of Blender's exporter, or the primitive's ``extras``); a
primitive without a target contributes zeros to it. Base colours come from ``COLOR_0`` and
``baseColorFactor`` per vertex and from the ``baseColor`` textures per pixel, every material's
in one atlas with its alpha mode; the specular strength from the material's roughness and
metalness (:mod:`renderer.gltfmaterial`). Normals are unit length whatever the node
transforms' scale. VRM 0.x avatars face -z and are turned half round about y so that every
avatar faces +z, as glTF and the renderer expect (Khronos, glTF 2.0 sec. 3.4; VRM 1.0 "Model
orientation").

Writing is :mod:`renderer.gltfwrite`. pygltflib parses the container; accessors are decoded
with numpy (:mod:`renderer.gltfaccessor`).

Example
-------
>>> import numpy as np, tempfile, os
>>> from renderer.gltfwrite import MeshOut, write_glb
>>> tri = np.array([[0, 1, 2]]); v = np.eye(3)
>>> path = os.path.join(tempfile.mkdtemp(), "t.glb")
>>> _ = write_glb(path, MeshOut(v, np.tile([0, 0, 1.0], (3, 1)), tri,
...               np.ones((3, 4)), {"JawOpen": (v * 0.1, v * 0)}), bones=[], extras={})
>>> scene = read_gltf(path)
>>> scene.triangles.tolist(), sorted(scene.targets)
([[0, 1, 2]], ['JawOpen'])
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from renderer.gltfaccessor import read_accessor
from renderer.gltfdecode import check_required, unpack
from renderer.gltfmaterial import primitive_colors, texture_atlas
from renderer.gltfrig import bind_transforms, to_rest, vrm_expressions


@dataclass
class GltfScene:
    """The default scene of a glTF file, flattened (see the module docstring)."""

    vertices: np.ndarray  # (n, 3) float64
    normals: np.ndarray | None  # (n, 3), None if a primitive lacks them
    triangles: np.ndarray  # (m, 3) int64
    colors: np.ndarray  # (n, 4): RGB (display-referred, 0..1) and specular strength
    targets: dict[str, tuple[np.ndarray, np.ndarray]]  # name -> (dpos, dnormal), (n, 3)
    influence_nodes: np.ndarray  # (n, 4) node index of each skin joint (or the mesh node)
    influence_weights: np.ndarray  # (n, 4)
    node_names: list[str]
    parents: np.ndarray  # (k,) parent node index, -1 at a root
    world: np.ndarray  # (k, 4, 4) node world transforms at rest
    humanoid: dict[str, int] = field(default_factory=dict)  # VRM bone name -> node
    extras: dict[str, Any] = field(default_factory=dict)  # the file's root extras
    # the base colour textures of every primitive as one atlas to sample per pixel
    # (renderer.gltftexture): (n, 2) UVs into it, the (h, w, 3) uint8 image ((h, w, 4) when
    # some texels are cut out) and the colours without the texture (else all three None)
    uvs: np.ndarray | None = None
    texture: np.ndarray | None = None
    untextured_colors: np.ndarray | None = None
    # VRM expressions (0.x blendShapeMaster groups, 1.0 VRMC_vrm.expressions) by name, each the
    # weighted sum of the morph targets it binds: name -> (dpos, dnormal), (n, 3)
    expressions: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    # each node's mesh name ("" for none): eyes may be meshes named like eyes
    mesh_names: list[str] = field(default_factory=list)
    # whether each vertex is skinned (a head made of unskinned meshes turns as one)
    skinned: np.ndarray | None = None


def _load(path: Path):
    import pygltflib

    if not path.is_file():
        raise InputError("avatar file not found", path=path)
    try:
        with warnings.catch_warnings():  # pygltflib warns of several buffers: unpack() joins them
            warnings.simplefilter("ignore")
            if path.suffix.lower() == ".gltf":
                gltf = pygltflib.GLTF2().load_json(str(path))
            else:
                gltf = pygltflib.GLTF2().load_binary(str(path))
        if gltf is None:
            raise ValueError("not a glTF file")
        glb = gltf.binary_blob() or b""
    except InputError:
        raise
    except Exception as exc:  # pygltflib raises assorted types on malformed files
        reason = str(exc).strip().splitlines()[0][:120] if str(exc).strip() else type(exc).__name__
        raise InputError(f"not a readable glTF 2.0 / VRM file: {reason}", path=path) from None
    check_required(gltf, path)
    try:
        return gltf, unpack(gltf, glb, path)
    except InputError:
        raise
    except (IndexError, KeyError, TypeError, ValueError, AttributeError) as exc:
        reason = str(exc).strip().splitlines()[0][:120] if str(exc).strip() else type(exc).__name__
        raise InputError(f"malformed glTF buffers: {reason}", path=path) from None


def _quat_matrix(q: list[float]) -> np.ndarray:
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _local(node) -> np.ndarray:
    if node.matrix is not None:
        return np.array(node.matrix, dtype=np.float64).reshape(4, 4).T  # column-major
    m = np.eye(4)
    rs = _quat_matrix(node.rotation or [0, 0, 0, 1]) * np.array(node.scale or [1, 1, 1])
    m[:3, :3], m[:3, 3] = rs, node.translation or [0, 0, 0]
    return m


def _target_names(mesh, prim) -> list[str]:
    names = (prim.extras or {}).get("targetNames") or (mesh.extras or {}).get("targetNames")
    count = len(prim.targets or [])
    if not isinstance(names, list) or len(names) != count:
        return [f"target{k}" for k in range(count)]
    return [str(x) for x in names]


def _humanoid(gltf) -> tuple[dict[str, int], bool]:
    """VRM humanoid bone name -> node, and whether the file is VRM 0.x (facing -z)."""
    ext = gltf.extensions or {}
    if isinstance(ext.get("VRMC_vrm"), dict):  # VRM 1.0
        bones = ext["VRMC_vrm"].get("humanoid", {}).get("humanBones", {})
        return {
            k: int(v["node"])
            for k, v in bones.items()
            if isinstance(v, dict) and isinstance(v.get("node"), int)
        }, False
    if isinstance(ext.get("VRM"), dict):  # VRM 0.x
        bones = ext["VRM"].get("humanoid", {}).get("humanBones", [])
        return {
            str(b["bone"]): int(b["node"])
            for b in bones
            if isinstance(b, dict) and isinstance(b.get("node"), int) and "bone" in b
        }, True
    return {}, False


def read_gltf(path: str | Path) -> GltfScene:
    """Read a ``.glb``, ``.gltf`` or ``.vrm`` file (see the module docstring)."""
    path = Path(path)
    gltf, blob = _load(path)
    try:
        return _flatten(gltf, blob, path)
    except (IndexError, KeyError, TypeError, ValueError, AttributeError) as exc:
        if isinstance(exc, InputError):
            raise
        reason = str(exc).strip().splitlines()[0][:120] if str(exc).strip() else type(exc).__name__
        raise InputError(f"malformed glTF: {reason}", path=path) from None


def _flatten(gltf, blob: bytes, path: Path) -> GltfScene:
    """The default scene as one :class:`GltfScene` (see the module docstring)."""
    parents, world = _node_tree(gltf, path)
    humanoid, turned = _humanoid(gltf)
    parts: list[dict[str, Any]] = []
    offset = 0
    for i, node in enumerate(gltf.nodes):
        if node.mesh is None:
            continue
        mesh = gltf.meshes[node.mesh]
        skin = gltf.skins[node.skin] if node.skin is not None else None
        for prim in mesh.primitives:
            if prim.mode not in (None, 4) or prim.attributes.POSITION is None:
                continue  # points and lines are not drawn
            part = _primitive(gltf, blob, path, i, (mesh, skin, prim), world)
            part["tri"] = part["tri"] + offset
            parts.append(part)
            offset += len(part["pos"])
    if not parts or not sum(len(p["tri"]) for p in parts):
        raise InputError("no triangle mesh in the scene", path=path)
    scene = GltfScene(
        **_merged(parts, path),
        node_names=[str(node.name or f"node{i}") for i, node in enumerate(gltf.nodes)],
        parents=parents,
        world=world,
        humanoid=humanoid,
        extras=gltf.extras if isinstance(gltf.extras, dict) else {},
    )
    scene.expressions = vrm_expressions(gltf, parts, len(scene.vertices))
    scene.skinned = np.concatenate([np.full(len(p["pos"]), p["skinned"]) for p in parts])
    scene.mesh_names = [
        str(gltf.meshes[node.mesh].name or "") if node.mesh is not None else ""
        for node in gltf.nodes
    ]
    if any(p["texture"] for p in parts):
        scene.uvs, scene.texture, baked = texture_atlas(parts, scene.colors)
        scene.untextured_colors, scene.colors = scene.colors, baked
    if turned:
        _turn_half_round(scene)
    return scene


def _node_tree(gltf, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Each node's parent (-1 at a root) and its world transform at rest, (k, 4, 4)."""
    k = len(gltf.nodes)
    parents = np.full(k, -1)
    for i, node in enumerate(gltf.nodes):
        for c in node.children or []:
            if not 0 <= c < k:
                raise InputError(f"node {i} has a child {c} that does not exist", path=path)
            parents[c] = i
    world = np.zeros((k, 4, 4))
    done = np.zeros(k, bool)

    def resolve(i: int, depth: int = 0) -> np.ndarray:
        if not done[i]:
            if depth > k:
                raise InputError("the node hierarchy has a cycle", path=path)
            local = _local(gltf.nodes[i])
            world[i] = local if parents[i] < 0 else resolve(parents[i], depth + 1) @ local
            done[i] = True
        return world[i]

    for i in range(k):
        resolve(i)
    return parents, world


def _primitive(
    gltf, blob: bytes, path: Path, i: int, of: tuple[Any, Any, Any], world: np.ndarray
) -> dict[str, Any]:
    """Triangle primitive ``prim`` of node ``i``'s ``mesh`` (``of``: mesh, skin or None,
    primitive), read and placed in the scene's space: positions, normals, triangles (into its
    own vertices), morph target deltas by name and by index, influences, colours, texture."""
    mesh, skin, prim = of
    node = gltf.nodes[i]
    pos = read_accessor(gltf, blob, prim.attributes.POSITION, path)[:, :3]
    n = len(pos)
    nrm = (
        read_accessor(gltf, blob, prim.attributes.NORMAL, path)[:, :3]
        if prim.attributes.NORMAL is not None
        else None
    )
    flat = (
        read_accessor(gltf, blob, prim.indices, path).astype(np.int64).reshape(-1)
        if prim.indices is not None
        else np.arange(n)
    )
    tri = flat[: len(flat) // 3 * 3].reshape(-1, 3)
    if len(tri) and (tri.min() < 0 or tri.max() >= n):
        raise InputError(f"mesh {node.mesh}: indices beyond its {n} vertices", path=path)
    deltas = {}
    for name, t in zip(_target_names(mesh, prim), prim.targets or [], strict=True):
        dp = (
            read_accessor(gltf, blob, t["POSITION"], path)[:, :3]
            if isinstance(t, dict) and t.get("POSITION") is not None
            else np.zeros((n, 3))
        )
        dn = (
            read_accessor(gltf, blob, t["NORMAL"], path)[:, :3]
            if isinstance(t, dict) and t.get("NORMAL") is not None
            else np.zeros((n, 3))
        )
        deltas[name] = (dp, dn)
    skinned = (
        skin is not None
        and prim.attributes.JOINTS_0 is not None
        and prim.attributes.WEIGHTS_0 is not None
    )
    if skinned:
        joints = read_accessor(gltf, blob, prim.attributes.JOINTS_0, path).astype(int)
        if joints.max(initial=0) >= len(skin.joints):
            raise InputError(f"skin {node.skin}: joint index beyond its joints", path=path)
        nodes = np.asarray(skin.joints)[joints]
        weights = read_accessor(gltf, blob, prim.attributes.WEIGHTS_0, path)
        bind = (
            bind_transforms(
                read_accessor(gltf, blob, skin.inverseBindMatrices, path),
                world[np.asarray(skin.joints)],
                path,
            )
            if skin.inverseBindMatrices is not None
            else None
        )
        if bind is not None:
            pos, nrm, deltas = to_rest(bind[joints], weights, pos, nrm, deltas)
    else:
        pos, nrm, deltas = _by_node(world[i], pos, nrm, deltas)
        nodes = np.tile([i, i, i, i], (n, 1))
        weights = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    plain, texture = primitive_colors(gltf, blob, prim, n, path)
    return {
        "mesh": node.mesh,
        "skinned": skinned,
        "by_index": [deltas[name] for name in _target_names(mesh, prim)],
        "pos": pos,
        "nrm": nrm,
        "tri": tri,
        "deltas": deltas,
        "plain": plain,
        "texture": texture,
        "nodes": nodes,
        "weights": weights,
    }


def _by_node(
    m: np.ndarray,
    pos: np.ndarray,
    nrm: np.ndarray | None,
    deltas: dict[str, tuple[np.ndarray, np.ndarray]],
) -> tuple[np.ndarray, np.ndarray | None, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """An unskinned primitive taken to the scene's space by its node's world transform
    ``m``: positions by ``m``; normals and their deltas by the inverse transpose (row-wise),
    without its scale, so a delta stays in proportion to the unit normal it is added to."""
    pos = pos @ m[:3, :3].T + m[:3, 3]
    turn = np.linalg.inv(m[:3, :3])
    turn /= np.cbrt(max(abs(float(np.linalg.det(turn))), 1e-300))
    if nrm is not None:
        nrm = nrm @ turn
    for name, (dp, dn) in deltas.items():
        deltas[name] = (dp @ m[:3, :3].T, dn @ turn)
    return pos, nrm, deltas


def _merged(parts: list[dict[str, Any]], path: Path) -> dict[str, Any]:
    """The :class:`GltfScene` fields of the primitives as one vertex list: positions, unit
    normals (None unless every primitive has them), triangles, colours, influences, and each
    morph target across all of them (zeros in a primitive without it)."""
    names = list(dict.fromkeys(name for p in parts for name in p["deltas"]))
    zeros = [np.zeros((len(p["pos"]), 3)) for p in parts]
    targets = {
        name: tuple(
            np.vstack([p["deltas"].get(name, (z, z))[j] for p, z in zip(parts, zeros, strict=True)])
            for j in (0, 1)
        )
        for name in names
    }
    vertices = np.vstack([p["pos"] for p in parts])
    normals = None
    if all(p["nrm"] is not None for p in parts):
        # a node's scale (10 x 0.01 x 0.0019 on a gltfpack export) stretches its normals
        normals = np.vstack([p["nrm"] for p in parts])
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = np.where(length > 1e-12, normals / np.maximum(length, 1e-300), normals)
    if not np.isfinite(vertices).all():
        raise InputError("vertex positions must be finite numbers", path=path)
    return {
        "vertices": vertices,
        "normals": normals,
        "triangles": np.vstack([p["tri"] for p in parts]),
        "colors": np.vstack([p["plain"] for p in parts]),
        "targets": targets,
        "influence_nodes": np.vstack([p["nodes"] for p in parts]),
        "influence_weights": np.vstack([p["weights"] for p in parts]),
    }


def _turn_half_round(scene: GltfScene) -> None:
    """Turn a -z facing (VRM 0.x) scene by 180 degrees about y, in place."""
    flip = np.array([-1.0, 1.0, -1.0])
    scene.vertices = scene.vertices * flip
    if scene.normals is not None:
        scene.normals = scene.normals * flip
    scene.targets = {k: (dp * flip, dn * flip) for k, (dp, dn) in scene.targets.items()}
    scene.expressions = {k: (dp * flip, dn * flip) for k, (dp, dn) in scene.expressions.items()}
    turn = np.diag([-1.0, 1.0, -1.0, 1.0])
    scene.world = turn @ scene.world
