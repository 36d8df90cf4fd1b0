"""The mouth found from the shapes that open it, within the head (renderer.avatarmouth)."""

import numpy as np
import pytest

from app.errors import InputError
from renderer.avatar import AvatarRig, load_avatar
from renderer.avatarmouth import head_region, mouth_points, opening_shape

EYE_L, EYE_R = np.array([31.0, 0.0, 0.0]), np.array([-31.0, 0.0, 0.0])


def _head():
    """Lips, corners, a chin, a brow and a hand far below: (n, 3) in mm, eyes at y = 0."""
    return np.array(
        [
            [0, -60.0, 10],  # 0 upper lip
            [0, -75.0, 10],  # 1 lower lip
            [25, -68.0, 5],  # 2 corner
            [-25, -68.0, 5],  # 3 corner
            [0, -110.0, 5],  # 4 chin
            [20, 15.0, 5],  # 5 brow
            [0, -400.0, 40],  # 6 a hand
        ]
    )


def test_the_region_is_below_the_eyes_within_the_head():
    assert head_region(_head(), EYE_L, EYE_R).tolist() == [True] * 5 + [False, False]


def test_an_empty_jaw_open_gives_way_to_the_next_opening_shape():
    v = _head()
    empty = np.zeros_like(v)
    vroid = np.zeros_like(v)
    vroid[[1, 4]] = [0, -8, 0]
    hand = np.zeros_like(v)
    hand[6] = [0, -50, 0]
    region = head_region(v, EYE_L, EYE_R)
    shapes = {"jawOpen": empty, "Fcl_MTH_A": vroid, "handWave": hand}
    name, disp = opening_shape(shapes, region)
    assert name == "Fcl_MTH_A" and disp is vroid
    # no opening shape: the mouth shapes together, never a hand's
    name, disp = opening_shape({"jawOpen": empty, "mouthSmile_L": vroid, "x": hand}, region)
    assert name == "the mouth shapes together"
    assert opening_shape({"jawOpen": empty, "handWave": hand}, region) is None


def test_the_lips_are_found_and_a_hand_moving_more_is_ignored():
    v = _head()
    jaw = np.zeros_like(v)
    jaw[1] = [0, -8, 0]
    jaw[4] = [0, -9, 0]  # the chin too, behind the lip
    jaw[4, 2] = 0
    jaw[6] = [0, -80, 0]
    points = mouth_points(v, jaw, EYE_L, EYE_R)
    assert (points["2.2"], points["2.3"], points["2.4"], points["2.5"]) == (0, 1, 2, 3)
    with pytest.raises(InputError, match="moves no vertex below the eyes"):
        mouth_points(v, np.where(np.arange(7)[:, None] == 6, jaw, 0.0), EYE_L, EYE_R)


def test_an_avatar_whose_jaw_open_moves_no_lip_finds_its_mouth_by_another_shape(
    exported_head, tmp_path
):
    """VRoid's exports carry a jawOpen that moves nothing of the mouth; its Fcl_MTH_A opens
    the jaw. The lips are found from that, as the export's own feature points place them."""
    import pygltflib

    gltf = pygltflib.GLTF2().load_binary(str(exported_head))
    mesh = gltf.meshes[0]
    names, prim = mesh.extras["targetNames"], mesh.primitives[0]
    jaw, blink = names.index("jawOpen"), names.index("eyeBlinkLeft")
    prim.targets.append(dict(prim.targets[jaw]))
    names.append("Fcl_MTH_A")
    prim.targets[jaw] = dict(prim.targets[blink])  # "jawOpen" now moves an eyelid only
    points = gltf.extras["facepair"]["feature_points"]
    truth = {k: points.pop(k) for k in list(points) if k.startswith(("2.", "8."))}
    path = tmp_path / "vroid_like.glb"
    gltf.save_binary(str(path))
    avatar = load_avatar(path)
    v = avatar.vertices
    for k in ("2.2", "2.3"):
        assert np.linalg.norm(v[avatar.fp_vertices[k]] - v[truth[k]]) < 0.004, k  # 4 mm
    assert AvatarRig(avatar).mouth_ceiling < avatar.feature_points["3.5"][1]
