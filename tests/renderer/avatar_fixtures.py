"""Synthetic avatars with the structures of real ones, built from facepair's own head.

Avatars made by other tools reach facepair in shapes the exported built-in head never has.
Third-party assets are never shipped nor downloaded, so each builder here starts from the
built-in head (as :mod:`renderer.faceexport` does: its 52 ARKit shapes baked by the head's own
deformation), splits it into skin, eyeballs and mouth interior by its vertex groups, and writes
it as the tool in question lays out its files (node tree, naming, units, skinning, targets,
materials). Every byte is generated; only the structure follows the survey of real avatars:

========  ===================================================================================
facecap   three.js example ``facecap.glb`` (Bannaflak Face Cap, packed by gltfpack): no skin,
          scale nodes (10, 0.01, 0.01) with a +90 deg x turn, mirror-named eye nodes
          (``eyeLeft`` holds the character's right eye), ``eyeBlink_L`` targets on the head only
rpm       Ready Player Me: ``Wolf3D_Head``, ``EyeLeft``, ``EyeRight``, ``Wolf3D_Teeth`` on one
          skin, ``LeftEye``/``RightEye`` bones, sparse ARKit targets, a JPEG per material
vroid     VRoid Studio export without its VRM extension, re-packed by glTF-Transform: WebP
          textures only through ``EXT_texture_webp``, ``KHR_mesh_quantization`` dequantised by
          the inverse bind matrices, deep medial eye bones, brow and eyeline alpha cards,
          ``Fcl_*`` shapes and a "perfect sync" ARKit set whose ``jawOpen`` is empty
vrm1      VRM 1.0 from the Blender VRM add-on: ``VRMC_vrm`` humanoid and expressions, MToon
mixamo    Blender export of a Mixamo rig: ``mixamorig:`` bones in centimetres under a turned
          ``Armature``, ``blendShape1.`` prefixed targets, a grey+alpha (LA) PNG texture
========  ===================================================================================

Every file at rest is the built-in head in the world: metres, +y up, looking along +z, +x the
character's left (what :func:`renderer.gltfio.read_gltf` should produce from each of them).
"""

from __future__ import annotations

import functools
import io
import json
import math
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

KINDS: tuple[str, ...] = ("facecap", "rpm", "vroid", "vrm1", "mixamo")
#: eye node naming conventions seen in real avatars: convention -> (name of the character's left eye node, right)  # noqa: E501
EYE_NAMES: dict[str, tuple[str, str]] = {
    "eyeLeft": ("eyeLeft", "eyeRight"),  # three.js facecap (Face Cap)
    "grp_eyeLeft": ("grp_eyeLeft", "grp_eyeRight"),
    "Eye_L": ("Eye_L", "Eye_R"),
    "eye_L": ("eye_L", "eye_R"),
    "eye.L": ("eye.L", "eye.R"),  # Blender
    "L_Eye": ("L_Eye", "R_Eye"),
    "lEye": ("lEye", "rEye"),
    "LeftEye": ("LeftEye", "RightEye"),  # Ready Player Me bones
    "Left_Eye": ("Left_Eye", "Right_Eye"),
    "mixamorig:LeftEye": ("mixamorig:LeftEye", "mixamorig:RightEye"),
    "CC_Base_L_Eye": ("CC_Base_L_Eye", "CC_Base_R_Eye"),  # Character Creator
    "J_Adj_L_FaceEye": ("J_Adj_L_FaceEye", "J_Adj_R_FaceEye"),  # VRoid
    "FACIAL_L_Eye": ("FACIAL_L_Eye", "FACIAL_R_Eye"),
}
_STRUCTURES = {
    "facecap": "three.js facecap.glb (Face Cap via gltfpack): unskinned meshes under scale "
    "nodes turned +90 deg about x, mirror-named eyeLeft/eyeRight nodes, _L/_R targets",
    "rpm": "Ready Player Me: Wolf3D_Head/EyeLeft/EyeRight/Wolf3D_Teeth on one skin, "
    "LeftEye/RightEye bones, sparse ARKit targets, one JPEG texture per material",
    "vroid": "VRoid Studio without VRM via glTF-Transform: EXT_texture_webp, quantised "
    "positions dequantised by the skin, deep medial eye bones, brow/eyeline alpha cards",
    "vrm1": "VRM 1.0 (Blender VRM add-on): VRMC_vrm humanoid and expressions, MToon and "
    "unlit materials, PascalCase ARKit targets",
    "mixamo": "Blender export of a Mixamo rig: mixamorig: bones in cm under a turned "
    "Armature, Body mesh, blendShape1.-prefixed targets, grey+alpha PNG texture",
}
_GENERATORS = {
    "facecap": "gltfpack 0.13",
    "rpm": "Ready Player Me",
    "vroid": "glTF-Transform v4.3.0",
    "vrm1": "saturday06_blender_vrm_exporter_experimental_2.20.0",
    "mixamo": "Khronos glTF Blender I/O v3.6.27",
}

FLOAT, UINT, USHORT, SHORT, UBYTE, BYTE = 5126, 5125, 5123, 5122, 5121, 5120
_DTYPES = {FLOAT: np.float32, UINT: np.uint32, USHORT: np.uint16, SHORT: np.int16}
_DTYPES |= {UBYTE: np.uint8, BYTE: np.int8}
_TYPES = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4", 16: "MAT4"}
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
MM = 0.001  # the head's millimetres in metres
X90 = [math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4)]  # +90 deg about x (x, y, z, w)
UNTURN = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])  # -90 deg about x, X90's inverse
#: How a file stores the head's millimetres: data = scale * turn @ (p - origin).
Frame = tuple[np.ndarray, float, np.ndarray]
METRES: Frame = (np.eye(3), MM, np.zeros(3))
#: A skeleton's bones (keys of :meth:`_Head.bones`) and the nearest parent each may have.
_PARENTS = {"spine": "hips", "neck": "spine", "head": "neck", "eye_l": "head", "eye_r": "head"}
_PARENTS["top"] = "head"


@dataclass
class _Head:
    """The built-in head cut into parts, with its 52 ARKit shapes baked (millimetres). Rows
    past the head's own vertices are the alpha cards VRoid has (brow, eyelid line)."""

    vertices: np.ndarray  # (n, 3) mm
    normals: np.ndarray
    uvs: np.ndarray  # (n, 2) the built-in head's, into ``texture``
    texture: np.ndarray  # (h, w, 3) uint8
    eye_uvs: np.ndarray  # (n, 2) the iris map of :func:`_eye_uvs` (meant for eyeball rows)
    atlas: np.ndarray  # the texture with an eye (:func:`_eye_texture`) in a strip below it
    atlas_uvs: np.ndarray  # (n, 2) the head's UVs into ``atlas``, the eyeballs' on its eye
    head_weight: np.ndarray  # (n,) share of the head bone, the rest the neck's
    eye_centres: dict[str, np.ndarray]  # "l" (+x, the character's left), "r"
    pivot: np.ndarray  # feature point 7.1
    parts: dict[str, tuple[np.ndarray, np.ndarray]]  # name -> (vertex indices, local triangles)
    targets: dict[str, tuple[np.ndarray, np.ndarray]]  # ARKit spelling -> (dpos mm, dnormal)

    def bones(self) -> dict[str, np.ndarray]:
        """Bone positions (mm): a spine below the neck's cut, the head at 7.1, the eyes at the
        eyeball centres."""
        low, top, z = self.vertices[:, 1].min(), self.vertices[:, 1].max(), self.pivot[2]
        return {
            "hips": np.array([0.0, low - 400, z]),
            "spine": np.array([0.0, low - 200, z]),
            "neck": np.array([0.0, low + 60, z]),
            "head": self.pivot,
            "eye_l": self.eye_centres["l"],
            "eye_r": self.eye_centres["r"],
            "top": np.array([0.0, top, z]),
        }


def _strip(skin: np.ndarray, path: np.ndarray, half: float) -> tuple[np.ndarray, ...]:
    """A card along ``path`` (mm), ``half`` mm above and below it and 1 mm in front of the
    ``skin`` vertices: (vertices, triangles, uvs), u along the strip, v = 0 at its top."""
    k = len(path)
    verts = np.stack([path + [0, half, 0], path - [0, half, 0]], axis=1).reshape(-1, 3)
    for v in verts:
        near = (np.abs(skin[:, 0] - v[0]) < 4) & (np.abs(skin[:, 1] - v[1]) < 4)
        v[2] = (skin[near, 2].max() if near.any() else v[2]) + 1.0
    quads = np.arange(k - 1)[:, None] * 2
    tris = np.concatenate([quads + [0, 1, 2], quads + [2, 1, 3]])
    uvs = np.stack([np.repeat(np.linspace(0, 1, k), 2), np.tile([0.0, 1.0], k)], axis=1)
    return verts, tris, uvs


def _cards(skin: np.ndarray, centres: dict[str, np.ndarray], face) -> dict[str, tuple]:
    """VRoid's alpha cards, (vertices, triangles, uvs) each: ``brow``, a 12 mm band along each
    brow (feature points 4.1 to 4.6), and ``lid``, a 1.6 mm line along each upper lid."""
    fp = {k: np.asarray(p, np.float64) for k, p in face.feature_points.items()}
    t = np.linspace(np.pi, 0, 9)
    paths: dict[str, list[np.ndarray]] = {"brow": [], "lid": []}
    for side, sign, a, b, c in (("l", 1, "4.1", "4.3", "4.5"), ("r", -1, "4.2", "4.4", "4.6")):
        knots = np.stack([fp[a], fp[b], fp[c]])
        along = [np.interp(np.linspace(0, 2, 8), [0, 1, 2], knots[:, i]) for i in range(3)]
        paths["brow"].append(np.stack(along, axis=1))
        arc = [13 * sign * np.cos(t), 5.5 * np.sin(t), 0 * t]
        paths["lid"].append(centres[side] + np.stack(arc, axis=1))
    out = {}
    for part, half in (("brow", 6.0), ("lid", 0.8)):
        (v1, t1, uv1), (v2, t2, uv2) = (_strip(skin, p, half) for p in paths[part])
        out[part] = np.vstack([v1, v2]), np.vstack([t1, t2 + len(v1)]), np.vstack([uv1, uv2])
    return out


@functools.lru_cache(maxsize=1)
def _head() -> _Head:
    """The built-in head, its parts and shapes (cached; builders only read it)."""
    from app.stimuli.capture.arkit import BLENDSHAPES
    from renderer.avatar import shape_faps
    from renderer.deform import Rig
    from renderer.headmodel import builtin_face
    from renderer.shapenames import arkit_spelling

    face = builtin_face()
    rig = Rig(face)
    v = np.asarray(face.vertices, np.float64)
    n = len(v)
    label = np.zeros(n, int)
    for k, group in enumerate(("eyeball_l", "eyeball_r", "mouth_interior"), start=1):
        label[face.groups[group]] = k
    tris = np.asarray(face.triangles, np.int64)
    tri_label = label[tris]
    whole = tri_label.min(axis=1) == tri_label.max(axis=1)  # triangles spanning parts dropped
    parts = {}
    for k, part in enumerate(("skin", "eye_l", "eye_r", "mouth")):
        idx = np.flatnonzero(label == k)
        parts[part] = idx, np.searchsorted(idx, tris[whole & (tri_label[:, 0] == k)])
    # VRoid's EyeIris / EyeWhite: the eyeball triangles within 35 deg of +z of their centre,
    # and the rest (the vertices on the border belong to both)
    centres = {s: np.asarray(rig.eye_centres[s], np.float64) for s in "lr"}
    eyes = np.concatenate([parts["eye_l"][0], parts["eye_r"][0]])
    eye_tris = np.flatnonzero(whole & np.isin(tri_label[:, 0], (1, 2)))
    mid = v[tris[eye_tris]].mean(axis=1)
    d = mid - np.where(mid[:, :1] > 0, centres["l"], centres["r"])
    front = d[:, 2] > math.cos(math.radians(35)) * np.linalg.norm(d, axis=1)
    for part, mask in (("iris", front), ("white", ~front)):
        used, local = np.unique(tris[eye_tris[mask]], return_inverse=True)
        parts[part] = used, local.reshape(-1, 3)
    # VRoid's FaceBrow and Eyeline cards, appended as extra rows
    extra_v, extra_uv, start = [], [], n
    for part, (verts, local, card_uvs) in _cards(v[parts["skin"][0]], centres, face).items():
        parts[part] = np.arange(start, start + len(verts)), local
        extra_v.append(verts)
        extra_uv.append(card_uvs)
        start += len(verts)
    m = start - n
    all_v, tex = np.vstack([v, *extra_v]), np.asarray(face.texture, np.uint8)
    eye_uvs = _eye_uvs(all_v, centres)
    size = tex.shape[1] // 4  # the strip: one eye image, size x size, at its left
    atlas = np.vstack([tex, np.zeros((size, tex.shape[1], 3), np.uint8)])
    atlas[-size:, :size] = _eye_texture(size)
    uvs = np.vstack([np.asarray(face.uvs), *extra_uv]).astype(np.float64)
    atlas_uvs = uvs * [1, tex.shape[0] / len(atlas)]
    atlas_uvs[eyes] = (eye_uvs[eyes] * size + [0, tex.shape[0]]) / [tex.shape[1], len(atlas)]
    is_eye = np.isin(np.arange(start), eyes)[:, None]  # eyeballs turn by bones, not shapes
    targets = {}
    for name in BLENDSHAPES:  # all 52; those the table does not drive stay at rest
        frame = rig.deform(shape_faps(name))
        dp = np.vstack([frame.positions - rig.v0, np.zeros((m, 3))])
        dn = np.vstack([frame.normals - rig.n0, np.zeros((m, 3))])
        targets[arkit_spelling(name)] = np.where(is_eye, 0.0, dp), np.where(is_eye, 0.0, dn)
    return _Head(
        vertices=all_v,
        normals=np.vstack([rig.n0, np.tile([0.0, 0.0, 1.0], (m, 1))]).astype(np.float64),
        uvs=uvs,
        texture=tex,
        eye_uvs=eye_uvs,
        atlas=atlas,
        atlas_uvs=atlas_uvs,
        head_weight=np.concatenate([rig.weights["head"], np.ones(m)]),
        eye_centres=centres,
        pivot=np.asarray(face.pivot(), np.float64),
        parts=parts,
        targets=targets,
    )


class _Glb:
    """A glTF document under construction: its JSON and one binary chunk (glTF 2.0 sec. 4.4)."""

    def __init__(self, generator: str) -> None:
        self.doc: dict = {"asset": {"version": "2.0", "generator": generator}, "scene": 0}
        self.doc["scenes"] = [{"nodes": []}]
        self.blob = bytearray()

    def add(self, key: str, item: dict) -> int:
        """Append ``item`` to the top-level list ``key``; its index."""
        self.doc.setdefault(key, []).append(item)
        return len(self.doc[key]) - 1

    def view(self, data: bytes, target: int | None = None, stride: int | None = None) -> int:
        """A bufferView over ``data``, 4-byte aligned."""
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        view |= {k: v for k, v in (("target", target), ("byteStride", stride)) if v}
        self.blob.extend(data)
        return self.add("bufferViews", view)

    def accessor(self, array, component=FLOAT, *, target=ARRAY_BUFFER, bounds=False) -> int:
        """A dense accessor (integers into FLOAT-less types are normalised); vertex rows are
        padded to 4 bytes with a byteStride (glTF 2.0 sec. 3.6.2.4)."""
        rows = np.ascontiguousarray(array, _DTYPES[component])
        rows = rows.reshape(len(rows), -1)
        acc = {"componentType": component, "count": len(rows), "type": _TYPES[rows.shape[1]]}
        if component in (SHORT, BYTE):
            acc["normalized"] = True
        if bounds:
            acc["min"], acc["max"] = rows.min(axis=0).tolist(), rows.max(axis=0).tolist()
        stride = None
        if target == ARRAY_BUFFER and rows.shape[1] * rows.itemsize % 4:
            pad = -rows.shape[1] * rows.itemsize % 4 // rows.itemsize
            rows = np.hstack([rows, np.zeros((len(rows), pad), rows.dtype)])
            stride = rows.shape[1] * rows.itemsize
        acc["bufferView"] = self.view(rows.tobytes(), target, stride)
        return self.add("accessors", acc)

    def zeros(self, n: int) -> int:
        """A VEC3 accessor of ``n`` zeros with no data at all (no bufferView, no sparse)."""
        acc = {"componentType": FLOAT, "count": n, "type": "VEC3"}
        return self.add("accessors", acc | {"min": [0.0] * 3, "max": [0.0] * 3})

    def delta(self, array: np.ndarray, sparse: bool = False) -> int:
        """A morph target delta: no data if all zero, else dense or sparse (the moved rows)."""
        d = np.asarray(array, np.float32)
        moved = np.flatnonzero(np.abs(d).max(axis=1) > 0)
        if not len(moved):
            return self.zeros(len(d))
        if not sparse:
            return self.accessor(d, bounds=True)
        kind = USHORT if len(d) < 65536 else UINT
        acc = {"componentType": FLOAT, "count": len(d), "type": "VEC3"}
        acc["min"], acc["max"] = np.minimum(d.min(0), 0).tolist(), np.maximum(d.max(0), 0).tolist()
        indices = {"bufferView": self.view(moved.astype(_DTYPES[kind]).tobytes())}
        values = {"bufferView": self.view(d[moved].tobytes())}
        indices["componentType"] = kind
        acc["sparse"] = {"count": len(moved), "indices": indices, "values": values}
        return self.add("accessors", acc)

    def texture(self, pixels: np.ndarray, fmt: str) -> int:
        """An embedded image (PNG, JPEG or WEBP, encoded by Pillow) and a texture showing it;
        WebP only through EXT_texture_webp, with no plain ``source``, as glTF-Transform has it."""
        from PIL import Image

        out = io.BytesIO()
        options = {"PNG": {"compress_level": 1}, "JPEG": {"quality": 90}}
        options["WEBP"] = {"quality": 80, "method": 0}
        Image.fromarray(np.asarray(pixels, np.uint8)).save(out, format=fmt, **options[fmt])
        image = {"bufferView": self.view(out.getvalue()), "mimeType": f"image/{fmt.lower()}"}
        source = self.add("images", image)
        if "samplers" not in self.doc:
            self.add("samplers", {"magFilter": 9729, "minFilter": 9987})
        if fmt == "WEBP":
            ext = {"EXT_texture_webp": {"source": source}}
            return self.add("textures", {"sampler": 0, "extensions": ext})
        return self.add("textures", {"sampler": 0, "source": source})

    def material(self, name: str, texture: int | None, **extra) -> int:
        """A PBR material with ``texture`` as its base colour."""
        pbr: dict = {"baseColorFactor": [1.0] * 4, "metallicFactor": 0.0, "roughnessFactor": 0.9}
        if texture is not None:
            pbr["baseColorTexture"] = {"index": texture}
        return self.add("materials", {"name": name, "pbrMetallicRoughness": pbr, **extra})

    def node(self, name: str | None, parent: int | None = None, **fields) -> int:
        """A node under ``parent`` (else a scene root); numpy arrays become float lists."""
        node: dict[str, Any] = {"name": name} if name is not None else {}
        for key, value in fields.items():
            node[key] = [float(x) for x in value] if isinstance(value, list | np.ndarray) else value
        i = self.add("nodes", node)
        if parent is None:
            self.doc["scenes"][0]["nodes"].append(i)
        else:
            self.doc["nodes"][parent].setdefault("children", []).append(i)
        return i

    def mesh(self, name: str | None, primitives: list[dict], names: list[str] | tuple = ()) -> int:
        """A mesh; target names in ``extras.targetNames`` (Blender's and three.js' convention)."""
        mesh: dict = {"primitives": primitives} | ({"name": name} if name else {})
        if names:
            mesh["weights"], mesh["extras"] = [0.0] * len(names), {"targetNames": list(names)}
        return self.add("meshes", mesh)

    def save(self, path: Path) -> Path:
        """Write the binary glTF (.glb) container."""
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        self.doc["buffers"] = [{"byteLength": len(self.blob)}]
        text = json.dumps(self.doc, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 4)
        body = struct.pack("<I4s", len(text), b"JSON") + text
        body += struct.pack("<I4s", len(self.blob), b"BIN\0") + bytes(self.blob)
        path.write_bytes(b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body)
        return path


def _influences(n: int, *pairs) -> tuple[np.ndarray, np.ndarray]:
    """JOINTS_0 / WEIGHTS_0 from up to four (joint index, weight), scalars or per vertex."""
    joints, weights = np.zeros((n, 4), np.uint8), np.zeros((n, 4))
    for k, (joint, weight) in enumerate(pairs):
        joints[:, k], weights[:, k] = joint, weight
    return joints, weights


def _eye_texture(size: int = 128) -> np.ndarray:
    """White sclera, a brown iris (radius 0.085) and a black pupil (0.035) at the centre."""
    u = (np.arange(size) + 0.5) / size - 0.5
    r = np.hypot(u[None, :], u[:, None])[..., None]
    return np.where(r < 0.035, [10, 8, 8], np.where(r < 0.085, [110, 70, 40], [240, 238, 232]))


def _eye_uvs(v: np.ndarray, centres: dict[str, np.ndarray]) -> np.ndarray:
    """An azimuthal map of each eyeball (the centre on the vertex's side): its +z pole (the
    pupil) at the image centre, the angle from +z proportional to the radius (pi at 0.5), so
    a 30 deg iris reaches 0.083, as :func:`_eye_texture` draws it."""
    d = v - np.where(v[:, :1] > 0, centres["l"], centres["r"])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    theta, phi = np.arccos(np.clip(d[:, 2], -1, 1)), np.arctan2(d[:, 1], d[:, 0])
    return 0.5 + 0.5 * theta[:, None] / np.pi * np.stack([np.cos(phi), -np.sin(phi)], axis=1)


def _rig(g: _Glb, h: _Head, names: dict[str, str], root=None, frame=METRES, at=None, fold=None):
    """Bones ``names`` (a :meth:`_Head.bones` key -> node name) under ``root``, at those
    positions (or ``at``'s) in ``frame``, and one skin over them all whose inverse bind
    matrices are ``translate(-bone) @ fold`` (``fold``: the mesh data's frame in the
    skeleton's, e.g. a dequantisation). Returns (skin, {key: joint index}, {key: node})."""
    turn, scale, origin = frame
    where = h.bones() | (at or {})
    pos = {k: scale * turn @ (where[k] - origin) for k in names}
    nodes: dict[str, int] = {}
    for key, name in names.items():
        parent = _PARENTS.get(key)
        while parent and parent not in names:
            parent = _PARENTS.get(parent)
        local = pos[key] - pos[parent] if parent else pos[key]
        nodes[key] = g.node(name, nodes[parent] if parent else root, translation=local)
    ibm = np.tile(np.eye(4), (len(names), 1, 1))
    ibm[:, :3, 3] = -np.array(list(pos.values()))
    ibm = ibm @ (np.eye(4) if fold is None else fold)
    acc = g.accessor(ibm.transpose(0, 2, 1).reshape(-1, 16), target=None)
    joints = list(nodes.values())
    skin = g.add("skins", {"joints": joints, "inverseBindMatrices": acc, "skeleton": joints[0]})
    return skin, {k: i for i, k in enumerate(names)}, nodes


def _prim(g: _Glb, h: _Head, part: str, material: int, frame: Frame = METRES, **how) -> dict:
    """Part ``part`` as a triangle primitive, its vertices stored in ``frame``.

    ``how`` may say: ``joints`` ({bone key: joint index}) skins it: the skin to the head and
    neck by the head weight, eyeballs to their eye bone, the rest to the head. ``deltas``:
    morph targets (dpos, dnormal) over the whole head (with ``sparse``: sparse positions),
    ``targets``: the target dicts instead. ``uvs``: "eye" (:func:`_eye_uvs`) or "atlas"
    (:attr:`_Head.atlas_uvs`) instead of the head's UVs. ``quantised``: positions (then in
    -1..1) as normalised int16 and normals as int8 (KHR_mesh_quantization)."""
    idx, tris = h.parts[part]
    turn, scale, origin = frame
    pos, nrm = scale * (h.vertices[idx] - origin) @ turn.T, h.normals[idx] @ turn.T
    if how.get("quantised"):
        attrs = {"POSITION": g.accessor(np.round(pos * 32767), SHORT, bounds=True)}
        attrs["NORMAL"] = g.accessor(np.round(nrm * 127), BYTE)
    else:
        attrs = {"POSITION": g.accessor(pos, bounds=True), "NORMAL": g.accessor(nrm)}
    uvs = {"eye": h.eye_uvs, "atlas": h.atlas_uvs}.get(how.get("uvs") or "", h.uvs)
    attrs["TEXCOORD_0"] = g.accessor(uvs[idx])
    if (joints := how.get("joints")) is not None:
        hw, n = h.head_weight[idx], len(idx)
        eye = np.where(h.vertices[idx, 0] > 0, joints.get("eye_l", 0), joints.get("eye_r", 0))
        if part == "skin":
            inf = _influences(n, (joints["head"], hw), (joints["neck"], 1 - hw))
        else:
            is_eye = part in ("eye_l", "eye_r", "iris", "white")
            inf = _influences(n, (eye if is_eye else joints["head"], 1.0))
        attrs["JOINTS_0"], attrs["WEIGHTS_0"] = g.accessor(inf[0], UBYTE), g.accessor(inf[1])
    targets = how.get("targets")
    for dp, dn in how.get("deltas") or ():
        position = g.delta(scale * dp[idx] @ turn.T, how.get("sparse", False))
        targets = (targets or []) + [{"POSITION": position, "NORMAL": g.delta(dn[idx] @ turn.T)}]
    indices = g.accessor(tris.reshape(-1), UINT, target=ELEMENT_ARRAY_BUFFER)
    prim = {"attributes": attrs, "indices": indices, "material": material, "mode": 4}
    return prim | ({"targets": targets} if targets else {})


def _facecap(g: _Glb, h: _Head, left: str, right: str) -> None:
    """Face Cap as in three.js' facecap.glb (module docstring); ``left`` holds the -x eyeball.
    Only the eye nodes are renamed: with the ``grp_eyeLeft`` convention the group node and the
    eye node under it share the name (both sit at the eyeball centre).
    A node in grp_scale's frame has 0.1 m units, turned +90 deg; mesh nodes' data is in mm."""
    mat = g.material("lambert5", g.texture(h.atlas, "PNG"), doubleSided=True)
    grp = g.node("grp_scale", g.node("Empty", scale=[10.0] * 3), rotation=X90, scale=[0.01] * 3)
    names = []
    for name in h.targets:
        side = next((s for s in ("Left", "Right") if name.endswith(s)), "")
        sideless = name in ("jawLeft", "jawRight", "mouthLeft", "mouthRight")
        names.append(name if sideless or not side else f"{name[: -len(side)]}_{side[0]}")
    mouth = np.round(h.vertices[h.parts["mouth"][0]].mean(axis=0))
    for node, part, origin in (("head", "skin", h.pivot), ("teeth", "mouth", mouth)):
        deltas = h.targets.values() if part == "skin" else None
        prim = _prim(g, h, part, mat, (UNTURN, 1.0, origin), deltas=deltas, uvs="atlas")
        mesh = g.mesh(None, [prim], names if deltas else ())
        g.node(node, grp, mesh=mesh, translation=0.01 * UNTURN @ origin, scale=[0.01] * 3)
    for group, name, side in (("grp_eyeLeft", left, "r"), ("grp_eyeRight", right, "l")):
        centre = h.eye_centres[side]
        eye = g.node(name, g.node(group, grp, translation=0.01 * UNTURN @ centre))
        mesh = g.mesh(None, [_prim(g, h, f"eye_{side}", mat, (UNTURN, 1.0, centre), uvs="atlas")])
        g.node(None, eye, mesh=mesh, scale=[0.01] * 3)


def _rpm(g: _Glb, h: _Head, left: str, right: str) -> None:
    """Ready Player Me (module docstring)."""
    arm = g.node("Armature")
    bones = {"hips": "Hips", "spine": "Spine", "neck": "Neck", "head": "Head"}
    bones |= {"eye_l": left, "eye_r": right, "top": "HeadTop_End"}
    skin, joints, _ = _rig(g, h, bones, arm)
    teeth = g.texture(np.full((8, 8, 3), (236, 230, 214)), "JPEG")
    mats = {
        "skin": g.material("Wolf3D_Skin", g.texture(h.texture, "JPEG")),
        "eye": g.material("Wolf3D_Eye", g.texture(_eye_texture(), "JPEG")),
        "mouth": g.material("Wolf3D_Teeth", teeth),
    }
    names = list(h.targets)
    noise = np.random.default_rng(7)
    parts = {
        "Wolf3D_Head": "skin",
        "EyeLeft": "eye_l",
        "EyeRight": "eye_r",
        "Wolf3D_Teeth": "mouth",
    }
    for node, part in parts.items():
        idx, eye = h.parts[part][0], part.startswith("eye")
        how: dict[str, Any]
        if eye:  # every name, moving nothing, with float noise in the normals
            noisy = [g.accessor(noise.normal(0, 1e-7, (len(idx), 3))) for _ in names]
            how = {"targets": [{"POSITION": g.zeros(len(idx)), "NORMAL": k} for k in noisy]}
        else:
            how = {"deltas": h.targets.values(), "sparse": True}
        mat = mats["eye" if eye else part]
        prim = _prim(g, h, part, mat, joints=joints, uvs="eye" if eye else None, **how)
        if part == "skin":  # an unused second UV set, as RPM's heads have
            prim["attributes"]["TEXCOORD_1"] = g.accessor(h.uvs[idx])
        g.node(node, arm, mesh=g.mesh(node, [prim], names), skin=skin)


def _vroid(g: _Glb, h: _Head, left: str, right: str) -> None:
    """VRoid Studio re-packed by glTF-Transform (module docstring)."""
    g.doc["extensionsUsed"] = ["EXT_texture_webp", "KHR_mesh_quantization"]
    g.doc["extensionsRequired"] = list(g.doc["extensionsUsed"])
    deep = {f"eye_{s}": [0.4 * c[0], c[1], c[2] - 60.0] for s, c in h.eye_centres.items()}
    # one dequantisation for the whole mesh (one skin): data = (p - centre) / half extent
    materials = {"skin": "Face", "white": "EyeWhite", "iris": "EyeIris", "mouth": "FaceMouth"}
    materials |= {"brow": "FaceBrow", "lid": "Eyeline"}
    used = h.vertices[np.concatenate([h.parts[p][0] for p in materials])]
    centre = (used.min(axis=0) + used.max(axis=0)) / 2
    half = float(np.abs(used - centre).max())
    fold = np.diag([half * MM] * 3 + [1.0])
    fold[:3, 3] = centre * MM
    bones = {"hips": "J_Bip_C_Hips", "neck": "J_Bip_C_Neck", "head": "J_Bip_C_Head"}
    skin, joints, _ = _rig(g, h, bones | {"eye_l": left, "eye_r": right}, at=deep, fold=fold)
    t = h.targets
    brows = (t["browInnerUp"], t["browOuterUpLeft"], t["browOuterUpRight"])
    surprised = tuple(sum(b[i] for b in brows) for i in (0, 1))
    empty = tuple(np.zeros_like(a) for a in t["jawOpen"])
    names = ["Fcl_MTH_A", "Fcl_EYE_Close_L", "Fcl_EYE_Close_R", "Fcl_BRW_Surprised", *t]
    deltas = [t["jawOpen"], t["eyeBlinkLeft"], t["eyeBlinkRight"], surprised]
    deltas += [empty if k == "jawOpen" else d for k, d in t.items()]  # "perfect sync"
    v = (np.arange(64) + 0.5) / 64
    brow = np.abs(v[:, None] - 0.5) < 0.3 * (1 - 0.6 * v[None, :])  # tapering outwards
    line = np.tile(255 * (1 - np.abs(v[::4, None] - 0.5) * 2), (1, 64))
    from PIL import Image

    images = {
        "skin": h.texture,
        "white": np.full((8, 8, 3), 240),
        "iris": _eye_texture(),
        "mouth": np.asarray(Image.fromarray(h.texture).resize((256, 256))),
        "brow": np.dstack([np.full((64, 64, 3), (58, 40, 30)), 255 * brow]),
        "lid": np.dstack([np.full((16, 64, 3), 20), line]),
    }
    alpha: dict[str, dict[str, Any]] = {"brow": {"alphaMode": "MASK", "alphaCutoff": 0.5}}
    alpha["lid"] = {"alphaMode": "BLEND"}
    primitives = []
    for part, name in materials.items():
        mat = g.material(name, g.texture(images[part], "WEBP"), **alpha.get(part, {}))
        zero = g.zeros(len(h.parts[part][0]))
        how = (
            {"deltas": deltas} if part == "skin" else {"targets": [{"POSITION": zero}] * len(names)}
        )
        frame = (np.eye(3), 1 / half, centre)
        uvs = "eye" if part in ("iris", "white") else None
        primitives.append(
            _prim(g, h, part, mat, frame, joints=joints, uvs=uvs, quantised=True, **how)
        )
    g.node("Face", mesh=g.mesh("Face", primitives, names), skin=skin)


def _vrm1(g: _Glb, h: _Head, left: str, right: str) -> None:
    """VRM 1.0 from the Blender VRM add-on (module docstring)."""
    g.doc["extensionsUsed"] = ["KHR_materials_unlit", "VRMC_materials_mtoon", "VRMC_vrm"]
    arm = g.node("Armature")
    bones = {"hips": "Hips", "neck": "Neck", "head": "Head", "eye_l": left, "eye_r": right}
    skin, joints, nodes = _rig(g, h, bones, arm)
    tex = g.texture(h.atlas, "PNG")
    mtoon: dict[str, Any] = {"specVersion": "1.0", "shadeColorFactor": [0.8, 0.7, 0.7]}
    mtoon["shadeMultiplyTexture"] = {"index": tex}
    ext = {"KHR_materials_unlit": {}, "VRMC_materials_mtoon": mtoon}
    mats = {m: g.material(m, tex, extensions=ext) for m in ("Skin", "Eye", "Mouth")}
    names = [k[0].upper() + k[1:] for k in h.targets]
    parts = {"skin": "Skin", "eye_l": "Eye", "eye_r": "Eye", "mouth": "Mouth"}
    primitives = [
        _prim(g, h, part, mats[m], joints=joints, deltas=h.targets.values(), uvs="atlas")
        for part, m in parts.items()
    ]
    face = g.node("Face", arm, mesh=g.mesh("Face", primitives, names), skin=skin)

    def bind(*shapes: str) -> dict:
        binds = [{"node": face, "index": names.index(s), "weight": 1.0} for s in shapes]
        return {"morphTargetBinds": binds, "isBinary": False}

    human = {k: {"node": nodes[k]} for k in ("hips", "neck", "head")}
    human |= {"leftEye": {"node": nodes["eye_l"]}, "rightEye": {"node": nodes["eye_r"]}}
    meta = {"name": "facepair synthetic head", "authors": ["facepair tests"]}
    meta["licenseUrl"] = "https://vrm.dev/licenses/1.0/"
    preset = {"aa": bind("JawOpen"), "blink": bind("EyeBlinkLeft", "EyeBlinkRight")}
    vrm = {"specVersion": "1.0", "meta": meta, "humanoid": {"humanBones": human}}
    g.doc["extensions"] = {"VRMC_vrm": vrm | {"expressions": {"preset": preset}}}


def _mixamo(g: _Glb, h: _Head, left: str, right: str) -> None:
    """Blender export of a Mixamo rig in centimetres (module docstring)."""
    cm: Frame = (UNTURN, 0.1, np.zeros(3))  # the Armature's data frame: cm, turned back
    arm = g.node("Armature", rotation=X90, scale=[0.01] * 3)
    bones = {k: f"mixamorig:{k.title()}" for k in ("hips", "spine", "neck", "head")}
    bones |= {"eye_l": left, "eye_r": right, "top": "mixamorig:HeadTop_End"}
    skin, joints, _ = _rig(g, h, bones, arm, frame=cm)
    grey = np.round(np.asarray(h.atlas, np.float64) @ [0.299, 0.587, 0.114])
    mat = g.material("Material", g.texture(np.dstack([grey, np.full(grey.shape, 255)]), "PNG"))
    deltas = h.targets.values()
    body = [
        _prim(g, h, p, mat, cm, joints=joints, deltas=deltas, uvs="atlas")
        for p in ("skin", "mouth")
    ]
    eyes = [_prim(g, h, p, mat, cm, joints=joints, uvs="atlas") for p in ("eye_l", "eye_r")]
    names = [f"blendShape1.{k}" for k in h.targets]
    g.node("Body", arm, mesh=g.mesh("Body", body, names), skin=skin)
    g.node("Eyes", arm, mesh=g.mesh("Eyes", eyes), skin=skin)


_BUILDERS = {"facecap": _facecap, "rpm": _rpm, "vroid": _vroid, "vrm1": _vrm1, "mixamo": _mixamo}
_DEFAULT_EYES = {"facecap": "eyeLeft", "rpm": "LeftEye", "vroid": "J_Adj_L_FaceEye"}
_DEFAULT_EYES |= {"vrm1": "eye.L", "mixamo": "mixamorig:LeftEye"}


def build_avatar(kind: str, folder: Path, *, eye_names: tuple[str, str] | None = None, name: str | None = None) -> Path:  # noqa: E501  # fmt: skip
    """Write the synthetic avatar of structure `kind` into `folder` (file name `name` or f"{kind}.glb"); eye_names renames the two eye nodes (bones or mesh nodes, whatever that kind uses). Deterministic."""  # noqa: E501
    if kind not in _BUILDERS:
        raise ValueError(f"unknown avatar kind {kind!r}; one of {', '.join(KINDS)}")
    left, right = eye_names or EYE_NAMES[_DEFAULT_EYES[kind]]
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    g = _Glb(_GENERATORS[kind])
    _BUILDERS[kind](g, _head(), left, right)
    return g.save(folder / (name or f"{kind}.glb"))


def build_eye_mesh_only(folder: Path, left: str = "EyeLeft", right: str = "EyeRight") -> Path:
    """An avatar with NO eye bones at all: only two unskinned eyeball MESH nodes named like eyes (plus a skinned or unskinned head); eyes must be found from those mesh nodes."""  # noqa: E501
    h = _head()
    g = _Glb("facepair synthetic (eye meshes only)")
    arm = g.node("Armature")
    bones = {"hips": "Hips", "neck": "Neck", "head": "Head", "top": "HeadTop_End"}
    skin, joints, nodes = _rig(g, h, bones, arm)
    mat = g.material("Skin", g.texture(h.atlas, "PNG"))
    for node, part in (("Wolf3D_Head", "skin"), ("Wolf3D_Teeth", "mouth")):
        prim = _prim(g, h, part, mat, joints=joints, deltas=h.targets.values(), uvs="atlas")
        g.node(node, arm, mesh=g.mesh(node, [prim], list(h.targets)), skin=skin)
    for node, side in ((left, "l"), (right, "r")):  # children of the head bone, at the centres
        centre = h.eye_centres[side]
        mesh = g.mesh(node, [_prim(g, h, f"eye_{side}", mat, (np.eye(3), MM, centre), uvs="atlas")])
        g.node(node, nodes["head"], mesh=mesh, translation=(centre - h.pivot) * MM)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    return g.save(folder / "eye_mesh_only.glb")


def structure(kind: str) -> str:
    """One line describing what real avatar structure the kind reproduces (for docs/test ids)."""
    if kind not in _STRUCTURES:
        raise ValueError(f"unknown avatar kind {kind!r}; one of {', '.join(KINDS)}")
    return _STRUCTURES[kind]
