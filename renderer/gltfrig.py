"""Skins at rest and VRM expressions of a glTF scene, for :mod:`renderer.gltfio`.

Two things an avatar file states indirectly: where its skinned vertices sit at rest (their
joints' ``world @ inverseBindMatrix``, which quantising tools use to carry the dequantisation),
and what each VRM expression does (a weighted sum of morph targets, VRM 0.x and 1.0).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError


def vrm_binds(gltf) -> dict[str, list[tuple[int, int, float]]]:
    """VRM expression name -> its morph target binds as (mesh, target index, weight 0..1).

    VRM 0.x: ``extensions.VRM.blendShapeMaster.blendShapeGroups``, each with a ``presetName``
    (``unknown`` for custom ones, then its ``name``) and ``binds`` of mesh, index and a weight of
    0-100. VRM 1.0: ``extensions.VRMC_vrm.expressions.preset`` and ``.custom``, each with
    ``morphTargetBinds`` of node, index and a weight of 0-1.
    """
    ext = gltf.extensions or {}
    out: dict[str, list[tuple[int, int, float]]] = {}
    vrm1 = ext.get("VRMC_vrm") if isinstance(ext.get("VRMC_vrm"), dict) else None
    if vrm1 is not None:
        expressions = vrm1.get("expressions") or {}
        for group in ("preset", "custom"):
            for name, spec in (expressions.get(group) or {}).items():
                binds = spec.get("morphTargetBinds") if isinstance(spec, dict) else None
                for b in binds or []:
                    node = gltf.nodes[int(b["node"])]
                    if node.mesh is not None:
                        out.setdefault(str(name), []).append(
                            (node.mesh, int(b["index"]), _weight(b.get("weight", 1.0), 1.0))
                        )
        return out
    vrm0 = ext.get("VRM") if isinstance(ext.get("VRM"), dict) else None
    groups = ((vrm0 or {}).get("blendShapeMaster") or {}).get("blendShapeGroups") or []
    for g in groups:
        if not isinstance(g, dict):
            continue
        preset = str(g.get("presetName") or "unknown")
        name = str(g.get("name") or preset) if preset == "unknown" else preset
        for b in g.get("binds") or []:
            out.setdefault(name, []).append(
                (int(b["mesh"]), int(b["index"]), _weight(b.get("weight", 100.0), 100.0))
            )
    return out


def _weight(value: Any, full: float) -> float:
    """A bind's weight as a fraction of ``full`` (VRM 0.x: 100, 1.0: 1)."""
    w = float(value)
    if not np.isfinite(w):
        raise ValueError(f"expression weight {value!r} is not a finite number")
    return w / full


def vrm_expressions(
    gltf, parts: list[dict[str, Any]], n: int
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each VRM expression as the weighted sum of the morph targets it binds, on every vertex."""
    out = {}
    for name, binds in vrm_binds(gltf).items():
        dp, dn = np.zeros((n, 3)), np.zeros((n, 3))
        start = 0
        for part in parts:
            stop = start + len(part["pos"])
            for mesh, index, weight in binds:
                if part["mesh"] == mesh and 0 <= index < len(part["by_index"]):
                    dp[start:stop] += weight * part["by_index"][index][0]
                    dn[start:stop] += weight * part["by_index"][index][1]
            start = stop
        if np.abs(dp).any():
            out[name] = (dp, dn)
    return out


def bind_transforms(ibm: np.ndarray, joint_world: np.ndarray, path: Path) -> np.ndarray | None:
    """Each joint's ``world @ inverseBindMatrix``, or None where all are the identity.

    ``ibm`` is the skin's accessor ((joints, 16), column-major), ``joint_world`` the joints'
    world transforms at rest. A skinned vertex at rest sits at the weighted sum of these times
    its stored position (glTF 2.0 sec. 3.7.3). Exporters usually bind at the rest pose, so they
    are the identity; quantising tools (gltfpack, glTF-Transform ``quantize``) fold the
    dequantisation into the inverse bind matrices instead of the node, which a skinned mesh
    ignores.
    """
    if ibm.shape != (len(joint_world), 16):
        raise InputError("skin: inverseBindMatrices do not match its joints", path=path)
    bind = joint_world @ ibm.reshape(-1, 4, 4).transpose(0, 2, 1)
    if np.allclose(bind, np.eye(4), atol=1e-6):
        return None
    return bind


def to_rest(
    bind: np.ndarray,
    weights: np.ndarray,
    pos: np.ndarray,
    nrm: np.ndarray | None,
    deltas: dict[str, tuple[np.ndarray, np.ndarray]],
) -> tuple[np.ndarray, np.ndarray | None, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """Vertices (and normals, target deltas) skinned to the rest pose by linear blend skinning."""
    total = weights.sum(axis=1, keepdims=True)
    w = weights / np.where(total > 0, total, 1.0)
    m = np.einsum("vj,vjab->vab", w, bind)  # (n, 4, 4) per-vertex blend
    lin = m[:, :3, :3]
    pos = np.einsum("vab,vb->va", lin, pos) + m[:, :3, 3]
    inv_t = np.linalg.inv(lin).transpose(0, 2, 1)
    # normals and their deltas turn with the mesh but keep their length (the dequantisation is
    # a uniform scale in practice): the inverse transpose divided by its mean scale
    inv_t /= np.cbrt(np.abs(np.linalg.det(inv_t)))[:, None, None]
    if nrm is not None:
        nrm = np.einsum("vab,vb->va", inv_t, nrm)
        nrm = nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
    deltas = {
        name: (np.einsum("vab,vb->va", lin, dp), np.einsum("vab,vb->va", inv_t, dn))
        for name, (dp, dn) in deltas.items()
    }
    return pos, nrm, deltas
