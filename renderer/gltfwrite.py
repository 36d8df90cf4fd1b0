"""glTF 2.0 out: one skinned primitive with named morph targets as a binary glTF (.glb).

The inverse of :func:`renderer.gltfio.read_gltf` for what :mod:`renderer.faceexport` writes:
the built-in head as an avatar any glTF tool (and this renderer) can read. pygltflib writes
the container; the accessors are encoded here with numpy (Khronos, glTF 2.0 sec. 3.6-3.7).

Example
-------
>>> import numpy as np, tempfile, os
>>> from renderer.gltfio import read_gltf
>>> v = np.eye(3)
>>> path = write_glb(os.path.join(tempfile.mkdtemp(), "t.glb"),
...                  MeshOut(v, np.tile([0, 0, 1.0], (3, 1)), np.array([[0, 1, 2]]),
...                          np.ones((3, 4)), {"JawOpen": (v * 0.1, v * 0)}),
...                  bones=[], extras={})
>>> sorted(read_gltf(path).targets)
['JawOpen']
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from renderer.gltfaccessor import COMPONENT_TYPES
from renderer.gltfmaterial import SPECULAR_ATTRIBUTE


@dataclass
class MeshOut:
    """One skinned primitive to write: vertices, normals, triangles, colours (display RGB and
    specular strength) and morph targets name -> (dpos, dnormal)."""

    vertices: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    colors: np.ndarray
    targets: dict[str, tuple[np.ndarray, np.ndarray]]
    joints: np.ndarray | None = None  # (n, 4) indices into ``bones``
    weights: np.ndarray | None = None  # (n, 4)
    uvs: np.ndarray | None = None  # (n, 2) TEXCOORD_0, v = 0 at the image's first row
    texture: np.ndarray | None = None  # (h, w, 3) uint8 baseColor image, display-referred


def write_glb(
    path: str | Path,
    mesh: MeshOut,
    *,
    bones: list[tuple[str, int, np.ndarray]],
    extras: dict[str, Any],
) -> Path:
    """Write ``mesh`` as a binary glTF: one node with the mesh, skinned to ``bones``
    (name, parent index or -1, world position), and ``extras`` on the root.

    Colours go to ``COLOR_0`` in linear light (glTF's convention: the display value squared,
    the renderer's gamma), the specular strength to :data:`SPECULAR_ATTRIBUTE`; a texture with
    UVs becomes the material's ``baseColorTexture`` (a PNG in the binary chunk) and
    ``TEXCOORD_0``.
    """
    import pygltflib as g

    blob = bytearray()
    views: list[g.BufferView] = []
    accessors: list[g.Accessor] = []

    def add(
        array: np.ndarray,
        kind: str,
        component: int,
        target: int | None = None,
        bounds: bool = False,
    ) -> int:
        data = np.ascontiguousarray(array, dtype=COMPONENT_TYPES[component])
        while len(blob) % 4:
            blob.append(0)
        views.append(
            g.BufferView(buffer=0, byteOffset=len(blob), byteLength=data.nbytes, target=target)
        )
        blob.extend(data.tobytes())
        flat = data.reshape(len(data), -1)
        accessors.append(
            g.Accessor(
                bufferView=len(views) - 1,
                componentType=component,
                count=len(data),
                type=kind,
                min=flat.min(axis=0).tolist() if bounds else None,
                max=flat.max(axis=0).tolist() if bounds else None,
            )
        )
        return len(accessors) - 1

    f32, vertex_buffer = g.FLOAT, g.ARRAY_BUFFER
    attributes = g.Attributes(
        POSITION=add(mesh.vertices, "VEC3", f32, vertex_buffer, bounds=True),
        NORMAL=add(mesh.normals, "VEC3", f32, vertex_buffer),
        COLOR_0=add(np.clip(mesh.colors[:, :3], 0, 1) ** 2, "VEC3", f32, vertex_buffer),
    )
    setattr(attributes, SPECULAR_ATTRIBUTE, add(mesh.colors[:, 3], "SCALAR", f32, vertex_buffer))
    if bones and mesh.joints is not None and mesh.weights is not None:
        attributes.JOINTS_0 = add(mesh.joints, "VEC4", g.UNSIGNED_BYTE, vertex_buffer)
        attributes.WEIGHTS_0 = add(mesh.weights, "VEC4", f32, vertex_buffer)
    targets = [
        {
            "POSITION": add(dp, "VEC3", f32, vertex_buffer, bounds=True),
            "NORMAL": add(dn, "VEC3", f32, vertex_buffer),
        }
        for dp, dn in mesh.targets.values()
    ]
    indices = add(mesh.triangles.reshape(-1), "SCALAR", g.UNSIGNED_INT, g.ELEMENT_ARRAY_BUFFER)
    names = list(mesh.targets)
    material = g.PbrMetallicRoughness(
        baseColorFactor=[1, 1, 1, 1], metallicFactor=0.0, roughnessFactor=0.6
    )
    images, textures, samplers = [], [], []
    if mesh.uvs is not None and mesh.texture is not None:
        import imageio.v3 as iio

        attributes.TEXCOORD_0 = add(mesh.uvs, "VEC2", f32, vertex_buffer)
        png = iio.imwrite("<bytes>", np.asarray(mesh.texture, np.uint8), extension=".png")
        while len(blob) % 4:
            blob.append(0)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(png)))
        blob.extend(png)
        images.append(g.Image(bufferView=len(views) - 1, mimeType="image/png"))
        samplers.append(
            g.Sampler(
                magFilter=g.LINEAR,
                minFilter=g.LINEAR_MIPMAP_NEAREST,
                wrapS=g.REPEAT,
                wrapT=g.REPEAT,
            )
        )
        textures.append(g.Texture(source=0, sampler=0))
        material.baseColorTexture = g.TextureInfo(index=0)
    primitive = g.Primitive(attributes=attributes, indices=indices, material=0, targets=targets)
    nodes = [g.Node(name="face", mesh=0, skin=0 if bones else None)]
    first_bone = len(nodes)
    for k, (name, parent, position) in enumerate(bones):
        origin = bones[parent][2] if parent >= 0 else np.zeros(3)
        nodes.append(g.Node(name=name, translation=[float(x) for x in position - origin]))
        if parent >= 0:
            nodes[first_bone + parent].children.append(first_bone + k)
    skins = []
    if bones:
        inverse = np.tile(np.eye(4), (len(bones), 1, 1))
        inverse[:, :3, 3] = -np.array([b[2] for b in bones])
        skins.append(
            g.Skin(
                joints=list(range(first_bone, first_bone + len(bones))),
                inverseBindMatrices=add(inverse.transpose(0, 2, 1).reshape(-1, 16), "MAT4", f32),
            )
        )
    roots = [0] + [first_bone + k for k, b in enumerate(bones) if b[1] < 0]
    gltf = g.GLTF2(
        asset=g.Asset(version="2.0", generator="facepair"),
        scene=0,
        scenes=[g.Scene(nodes=roots)],
        nodes=nodes,
        skins=skins,
        meshes=[
            g.Mesh(
                name="face",
                primitives=[primitive],
                weights=[0.0] * len(names),
                extras={"targetNames": names},
            )
        ],
        materials=[g.Material(name="skin", pbrMetallicRoughness=material)],
        images=images,
        textures=textures,
        samplers=samplers,
        accessors=accessors,
        bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob))],
        extras=extras,
    )
    gltf.set_binary_blob(bytes(blob))
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    gltf.save_binary(str(out))
    return out
