"""An avatar's names for what the ARKit table drives: the table's shapes and bones, shapes found
in any naming convention, bones by name and by the skin they hold (no GL needed)."""

import numpy as np

from renderer.avatarnames import driven, find_shapes, skin_share, subtree
from renderer.gltfio import read_gltf


def test_driven_table_names_shapes_bones_and_their_faps():
    shapes, bones = driven()
    assert shapes["JawOpen"] == [3]
    assert sorted(shapes["BrowDownLeft"]) == [31, 33, 35]
    assert sorted(bones["head"]) == [48, 49, 50] and sorted(bones["leftEye"]) == [23, 25]


def test_subtree_is_the_root_and_everything_below_it():
    parents = np.array([-1, 0, 1, 0, -1])
    assert subtree(parents, 1).tolist() == [False, True, True, False, False]
    assert subtree(parents, 0).tolist() == [True, True, True, True, False]


def test_shapes_are_found_in_any_convention_and_renamed_by_the_sidecar(exported_head):
    scene = read_gltf(exported_head)
    shapes, drives = find_shapes(scene, ["JawOpen", "EyeBlinkLeft"], {})
    assert np.array_equal(shapes["JawOpen"][0], scene.targets["jawOpen"][0]) and not drives
    scene.targets = {
        "blendShape1.eyeBlink_L": scene.targets["eyeBlinkLeft"],
        "open": scene.targets["jawOpen"],
    }
    shapes, _ = find_shapes(scene, ["JawOpen", "EyeBlinkLeft"], {"jawOpen": "open"})
    assert np.array_equal(shapes["EyeBlinkLeft"][0], scene.targets["blendShape1.eyeBlink_L"][0])
    assert np.array_equal(shapes["JawOpen"][0], scene.targets["open"][0])


def test_the_head_bone_holds_the_whole_exported_head(exported_head):
    scene = read_gltf(exported_head)
    head = scene.node_names.index("head")
    share = skin_share(scene, head)
    assert share.shape == (len(scene.vertices),) and share.max() <= 1.0 + 1e-9
    assert share.mean() > 0.5
