"""The built-in head as a glTF 2.0 avatar with ARKit-named morph targets (``face export``).

Each blendshape the ARKit table drives (:func:`renderer.avatar.driven`) and each mouth shape of
:mod:`renderer.lips` is baked as the built-in deformation of the FAPs it stands for at weight 1
(:func:`renderer.avatar.shape_faps`): ``jawOpen`` is the jaw opened by FAP 3 = 800,
``browInnerUp`` the inner and middle brows raised by 100 and 50 units, ``mouthUpperUpLeft`` the
upper lip's left raised by 200 units, and so on, with the normals of the deformed skin as
normal deltas. Targets are named in ARKit's own spelling (``eyeBlinkLeft``, Apple's
``ARFaceAnchor.BlendShapeLocation``), which three.js, Blender add-ons and ARKit rigs expect.
The skeleton carries the VRM humanoid names the avatar reader looks for:
``upperChest`` (the shoulders, which never turn), ``head`` at feature point 7.1 (the vertices
weighted by the head's ``head`` layer, so the neck blends as on the built-in head), and
``leftEye`` / ``rightEye`` at the eyeball centres. Feature points and the hidden-outline group
go to the root ``extras.facepair`` (the sidecar schema), so the avatar frames and mosaics
exactly as the built-in head. The skin texture (:mod:`renderer.skintexture`) goes along as
the ``baseColor`` texture with ``TEXCOORD_0``. Units are metres, as glTF specifies; axes are
glTF's (+y up, +z forward, +x the face's left), which are Xface's.

Example
-------
>>> import tempfile, os
>>> from renderer.gltfio import read_gltf
>>> path = export_builtin_head(os.path.join(tempfile.mkdtemp(), "head.glb"))
>>> sorted(read_gltf(path).targets)[:3]
['browDownLeft', 'browDownRight', 'browInnerUp']
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from renderer.avatar import shape_faps
from renderer.avatarnames import driven
from renderer.deform import Rig
from renderer.gltfwrite import MeshOut, write_glb
from renderer.headmodel import builtin_face
from renderer.lips import MOUTH_SHAPES
from renderer.shapenames import arkit_spelling

#: Model units (millimetres) to glTF's metres.
METRES = 0.001


def export_builtin_head(path: str | Path) -> Path:
    """Write the built-in head as a binary glTF (``.glb``) avatar; returns the path."""
    face = builtin_face()
    rig = Rig(face)
    targets = {}
    for name in (*driven()[0], *MOUTH_SHAPES):
        frame = rig.deform(shape_faps(name))
        delta = (frame.positions - rig.v0) * METRES, frame.normals - rig.n0
        targets[arkit_spelling(name)] = delta
    n = face.n_vertices
    head_w = np.asarray(rig.weights["head"], dtype=np.float64)
    joints = np.zeros((n, 4), np.uint8)
    weights = np.zeros((n, 4))
    joints[:, 0], joints[:, 1] = 1, 0
    weights[:, 0], weights[:, 1] = head_w, 1.0 - head_w
    for k, side in ((2, "l"), (3, "r")):
        eye = rig.eye_vertices[side]
        joints[eye, 0], weights[eye] = k, (1.0, 0.0, 0.0, 0.0)
    low = float(face.vertices[:, 1].min())
    bones = [
        ("upperChest", -1, np.array([0.0, low, 0.0]) * METRES),
        ("head", 0, face.pivot() * METRES),
        ("leftEye", 1, rig.eye_centres["l"] * METRES),
        ("rightEye", 1, rig.eye_centres["r"] * METRES),
    ]
    points = {
        k: (
            face.fp_vertices[k]
            if k in face.fp_vertices
            else [float(x) * METRES for x in face.feature_points[k]]
        )
        for k in sorted(face.feature_points)
    }
    extras = {
        "facepair": {
            "feature_points": points,
            "groups": {
                k: [int(i) for i in v]
                for k, v in face.groups.items()
                if not k.startswith("eyeball")
            },
        }
    }
    mesh = MeshOut(
        vertices=face.vertices * METRES,
        normals=rig.n0,
        triangles=face.triangles,
        colors=face.colors,
        targets=targets,
        joints=joints,
        weights=weights,
        uvs=face.uvs,
        texture=face.texture,
    )
    return write_glb(path, mesh, bones=bones, extras=extras)
