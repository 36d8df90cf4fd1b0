"""Writing glTF: what write_glb writes, read_gltf reads back."""

import numpy as np
import pygltflib
from hypothesis import given, settings
from hypothesis import strategies as st

from renderer.gltfio import read_gltf
from renderer.gltfwrite import MeshOut, write_glb


def _quad(colors):
    v = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    normals = np.tile([0, 0, 1.0], (4, 1))
    return MeshOut(
        v,
        normals,
        tri,
        colors,
        {"JawOpen": (v * 0.1, v * 0.0), "BrowUp": (v * 0.0 + [0, 0.2, 0], v * 0.0)},
        joints=np.zeros((4, 4), np.uint8),
        weights=np.tile([1.0, 0, 0, 0], (4, 1)),
    )


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=16, max_size=16))
def test_geometry_targets_and_colours_read_back(tmp_path_factory, values):
    colors = np.array(values).reshape(4, 4)
    mesh = _quad(colors)
    path = write_glb(
        tmp_path_factory.mktemp("glb") / "quad.glb",
        mesh,
        bones=[("head", -1, np.array([0.0, 0.5, 0.0]))],
        extras={"by": "test"},
    )
    scene = read_gltf(path)
    np.testing.assert_allclose(scene.vertices, mesh.vertices, atol=1e-6)
    assert scene.triangles.tolist() == mesh.triangles.tolist()
    assert list(scene.targets) == ["JawOpen", "BrowUp"]
    np.testing.assert_allclose(scene.targets["BrowUp"][0], mesh.targets["BrowUp"][0], atol=1e-6)
    np.testing.assert_allclose(scene.colors[:, 3], colors[:, 3], atol=1e-6)
    np.testing.assert_allclose(scene.colors[:, :3], colors[:, :3], atol=1e-3)
    assert scene.extras == {"by": "test"}


def test_bones_become_a_skin_with_inverse_bind_matrices(tmp_path):
    bones = [("neck", -1, np.array([0.0, -1.0, 0.0])), ("head", 0, np.array([0.0, 0.5, 0.0]))]
    path = write_glb(tmp_path / "quad.glb", _quad(np.ones((4, 4))), bones=bones, extras={})
    gltf = pygltflib.GLTF2().load_binary(str(path))
    (skin,) = gltf.skins
    names = [gltf.nodes[j].name for j in skin.joints]
    assert names == ["neck", "head"]
    head = gltf.nodes[skin.joints[1]]
    np.testing.assert_allclose(head.translation, [0.0, 1.5, 0.0])  # relative to its parent
    assert skin.joints[1] in gltf.nodes[skin.joints[0]].children
