"""glTF avatars: driven by the ARKit table, clear errors for what is missing, mouth found."""

import json

import numpy as np
import pygltflib
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cli import main
from app.errors import InputError
from renderer.avatar import AvatarRig, load_avatar, mouth_points
from renderer.deform import Rig
from renderer.headmodel import builtin_face
from renderer.pipeline import render_frames


def _edited(exported_head, tmp_path, edit, name="avatar.glb"):
    gltf = pygltflib.GLTF2().load_binary(str(exported_head))
    edit(gltf)
    out = tmp_path / name
    gltf.save_binary(str(out))
    return out


def _rename_target(old, new):
    def edit(gltf):
        names = gltf.meshes[0].extras["targetNames"]
        names[names.index(old)] = new

    return edit


def _rename_node(old, new):
    def edit(gltf):
        next(n for n in gltf.nodes if n.name == old).name = new

    return edit


def test_missing_blendshape_names_it_and_its_faps(exported_head, tmp_path):
    path = _edited(exported_head, tmp_path, _rename_target("jawOpen", "mouth_open"))
    with pytest.raises(InputError) as err:
        load_avatar(path)
    message = str(err.value)
    assert "blendshape jawOpen (FAP 3)" in message and "\n" not in message
    assert str(path) in message
    # the sidecar renames it, and the avatar loads
    path.with_name("avatar.avatar.json").write_text(
        json.dumps({"blendshapes": {"JawOpen": "mouth_open"}})
    )
    assert "JawOpen" in load_avatar(path).targets


def test_eyes_no_name_can_find_are_refused_naming_what_was_found(exported_head, tmp_path):
    path = _edited(exported_head, tmp_path, _rename_node("leftEye", "joint7"))
    with pytest.raises(InputError) as err:
        load_avatar(path)
    message = str(err.value)
    assert message.startswith(f"{path}: the eyes cannot be found (nodes naming an eye: rightEye)")
    assert "avatar.avatar.json" in message and "\n" not in message
    path.with_name("avatar.avatar.json").write_text(
        json.dumps({"bones": {"leftEye": "joint7", "rightEye": "rightEye"}})
    )
    assert len(load_avatar(path).groups["eyeball_l"]) > 0
    # an eye named without a side is told from its partner by where it is
    path = _edited(exported_head, tmp_path, _rename_node("leftEye", "eyeball"), "b.glb")
    avatar = load_avatar(path)
    assert avatar.eyes_found == "by place"
    assert avatar.eye_pivots["l"][0] > avatar.eye_pivots["r"][0]


def test_bone_names_match_common_rig_spellings(exported_head, tmp_path):
    path = _edited(exported_head, tmp_path, _rename_node("head", "J_Bip_C_Head"))
    assert load_avatar(path).weights["head"].max() == 1.0


def test_cli_reports_a_missing_blendshape_in_one_line(exported_head, tmp_path):
    path = _edited(exported_head, tmp_path, _rename_target("eyeBlinkLeft", "blink"))
    track = tmp_path / "t.csv"
    track.write_text("# fps=30\nframe,fap49\n0,0\n1,100\n")
    result = CliRunner().invoke(
        main,
        [
            "render",
            "still",
            "--track",
            str(track),
            "--face",
            str(path),
            "--size",
            "64",
            "--out",
            str(tmp_path / "s.png"),
        ],
    )
    assert result.exit_code == 2, result.output
    assert "eyeBlinkLeft (FAP 19, 21)" in result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1


def test_avatar_rig_poses_as_the_builtin_rig(exported_head):
    """Head, eyes and raised brows: the avatar's vertices where the built-in head's are."""
    avatar, ref = AvatarRig(load_avatar(exported_head)), Rig(builtin_face())
    faps = np.zeros(68)
    faps[[47, 48, 49]] = (-8000.0, 20000.0, 5000.0)  # head pitch, yaw, roll
    faps[[22, 23, 24, 25]] = (15000.0, 15000.0, -9000.0, -9000.0)  # gaze
    # brows raised more inside than outside (the ARKit table carries inner and outer values;
    # the middle one is their mean, and BrowInnerUp is one shape for both sides)
    faps[30:36] = (60.0, 60.0, 50.0, 50.0, 40.0, 40.0)
    got = avatar.posed(avatar.deform(faps))[0] / 0.001
    want = ref.posed(ref.deform(faps))[0]
    assert np.abs(got - want).max() < 0.05  # millimetres
    assert np.abs(want - ref.posed(ref.deform(np.zeros(68)))[0]).max() > 5


def test_mouth_points_found_from_the_jaw_shape(exported_head):
    """Without feature points, the mouth comes from JawOpen near where the head has it."""
    face, ref = load_avatar(exported_head), builtin_face()
    eyes = [ref.feature_points[k] * 0.001 for k in ("3.5", "3.6")]
    found = mouth_points(face.vertices, face.targets["JawOpen"][0], *eyes)
    es = ref.fapu["ES0"]
    for name, tol in (("2.3", 0.1), ("2.2", 0.1), ("2.4", 0.2), ("2.5", 0.2)):
        err = np.linalg.norm(face.vertices[found[name]] / 0.001 - ref.feature_points[name])
        assert err < tol * es, (name, err / es)


def test_avatar_without_feature_points_frames_and_mosaics(exported_head, tmp_path):
    def strip(gltf):
        gltf.extras = {}

    path = _edited(exported_head, tmp_path, strip)
    face = load_avatar(path)
    assert {"2.2", "2.3", "8.3"} <= set(face.fp_vertices)
    jaw = np.zeros((2, 68))
    jaw[1, 2] = 600.0
    frames = list(render_frames([_track(jaw)], face, size=96, mosaic_block=8))
    closed, opened = frames[0], frames[1]
    assert closed.boxes == opened.boxes and closed.boxes[0][2] > closed.boxes[0][0]
    x0, y0, x1, y1 = closed.boxes[0]
    assert np.array_equal(closed.image[y0:y1, x0:x1], opened.image[y0:y1, x0:x1])


def _track(dense):
    from app.stimuli.track import MotionTrack

    return MotionTrack.from_channels(
        30.0, {k + 1: dense[:, k] for k in range(68) if dense[:, k].any()} or {49: dense[:, 48]}
    )


@settings(
    max_examples=30,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(data=st.binary(max_size=400), suffix=st.sampled_from([".glb", ".gltf", ".vrm"]))
def test_any_bytes_give_an_input_error_or_an_avatar(tmp_path, data, suffix):
    path = tmp_path / f"a{suffix}"
    path.write_bytes(data)
    with pytest.raises(InputError):
        load_avatar(path)


@settings(
    max_examples=30,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(
    doc=st.recursive(
        st.none() | st.booleans() | st.integers(-3, 3) | st.text(max_size=5),
        lambda c: (
            st.lists(c, max_size=3)
            | st.dictionaries(
                st.sampled_from(
                    [
                        "nodes",
                        "meshes",
                        "accessors",
                        "asset",
                        "scenes",
                        "buffers",
                        "version",
                        "mesh",
                        "children",
                    ]
                ),
                c,
                max_size=4,
            )
        ),
        max_leaves=12,
    )
)
def test_any_json_gives_an_input_error(tmp_path, doc):
    path = tmp_path / "a.gltf"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError):
        load_avatar(path)


def test_cache_key_follows_the_morph_targets(exported_head):
    """Clips are cached by the face's content hash: a changed blendshape is another face."""
    face = load_avatar(exported_head)
    before = face.content_hash()
    face.targets["JawOpen"][0][0, 1] += 1e-3
    assert face.content_hash() != before
    assert load_avatar(exported_head).content_hash() == before


def _renamed(rename):
    def edit(gltf):
        names = gltf.meshes[0].extras["targetNames"]
        gltf.meshes[0].extras["targetNames"] = [rename(n) for n in names]

    return edit


def _face_cap(name):  # eyeBlinkLeft -> eyeBlink_L
    for side, letter in (("Left", "_L"), ("Right", "_R")):
        if name.endswith(side) and name not in ("mouthLeft", "mouthRight"):
            return name[: -len(side)] + letter
    return name


@pytest.mark.parametrize(
    "convention,rename",
    [
        ("ARKit", lambda n: n),
        ("Live Link Face", lambda n: n[0].upper() + n[1:]),
        ("Face Cap", _face_cap),
        ("Blender sides", lambda n: _face_cap(n).replace("_L", ".L").replace("_R", ".R")),
        ("prefixed", lambda n: "blendShape1." + n),
    ],
)
def test_blendshape_names_match_in_every_convention(exported_head, tmp_path, convention, rename):
    reference = load_avatar(exported_head)
    face = load_avatar(_edited(exported_head, tmp_path, _renamed(rename)))
    assert set(face.targets) == set(reference.targets) and len(face.targets) == 27, convention
    for k in ("EyeBlinkLeft", "BrowDownRight", "MouthUpperUpLeft"):
        np.testing.assert_array_equal(face.targets[k][0], reference.targets[k][0])


def _vrm_expressions(version):
    """Targets renamed to VRoid-like mesh names; the shapes reachable only through VRM
    expressions: presets (blink, visemes) and ARKit-named custom ones (perfect sync)."""

    def edit(gltf):
        names = gltf.meshes[0].extras["targetNames"]
        index = {n: i for i, n in enumerate(names)}
        gltf.meshes[0].extras["targetNames"] = [f"Fcl_{i:02d}" for i in range(len(names))]
        mesh_node = next(i for i, n in enumerate(gltf.nodes) if n.mesh == 0)
        presets = {"aa": "jawOpen", "ou": "mouthPucker"}
        custom = {n[0].upper() + n[1:]: n for n in names if n.startswith("brow")}
        if version == 0:
            presets.update({"blink_l": "eyeBlinkLeft", "blink_r": "eyeBlinkRight"})
            groups = [
                {
                    "name": k,
                    "presetName": {"aa": "a", "ou": "u"}.get(k, k),
                    "binds": [{"mesh": 0, "index": index[v], "weight": 100}],
                }
                for k, v in presets.items()
            ] + [
                {
                    "name": k,
                    "presetName": "unknown",
                    "binds": [{"mesh": 0, "index": index[v], "weight": 100}],
                }
                for k, v in custom.items()
            ]
            gltf.extensions = {"VRM": {"blendShapeMaster": {"blendShapeGroups": groups}}}
        else:  # VRM 1.0: one blink for both eyes, as many avatars have

            def binds(v, w=1.0):
                return {"morphTargetBinds": [{"node": mesh_node, "index": index[v], "weight": w}]}

            preset = {k: binds(v) for k, v in presets.items()}
            preset["blink"] = {
                "morphTargetBinds": [
                    {"node": mesh_node, "index": index["eyeBlinkLeft"], "weight": 1.0},
                    {"node": mesh_node, "index": index["eyeBlinkRight"], "weight": 1.0},
                ]
            }
            gltf.extensions = {
                "VRMC_vrm": {
                    "expressions": {
                        "preset": preset,
                        "custom": {k: binds(v) for k, v in custom.items()},
                    }
                }
            }

    return edit


@pytest.mark.parametrize("version", [0, 1])
def test_vrm_expressions_drive_an_avatar(exported_head, tmp_path, version):
    reference = load_avatar(exported_head)
    name = "avatar.vrm"
    face = load_avatar(_edited(exported_head, tmp_path, _vrm_expressions(version), name))
    flip = np.array([-1.0, 1.0, -1.0]) if version == 0 else 1.0  # VRM 0.x faces -z
    np.testing.assert_allclose(
        face.targets["JawOpen"][0], reference.targets["JawOpen"][0] * flip, atol=1e-7
    )
    np.testing.assert_allclose(
        face.targets["BrowInnerUp"][0], reference.targets["BrowInnerUp"][0] * flip, atol=1e-7
    )
    assert face.drives["MouthPucker"] == ("MouthPucker",)
    if version == 1:  # one blink for both eyes takes the mean of their weights
        assert face.drives["blink"] == ("EyeBlinkLeft", "EyeBlinkRight")
        rig = AvatarRig(face)
        faps = np.zeros(68)
        faps[[18, 20]] = 1024 * 0.8  # the left lids closed
        lids = rig.deform(faps).positions - rig.v0
        both = reference.targets["EyeBlinkLeft"][0] + reference.targets["EyeBlinkRight"][0]
        np.testing.assert_allclose(lids, 0.5 * both * flip, atol=2e-4)
    else:
        assert "EyeBlinkLeft" in face.targets and "blink" not in face.targets


def test_lip_faps_move_an_avatars_lips_as_the_builtin_head(exported_head):
    """Lips within the mouth shapes' span: the avatar's lips where the built-in head's are."""
    from renderer.lips import mouth_faps

    avatar, ref = AvatarRig(load_avatar(exported_head)), Rig(builtin_face())
    faps = (
        0.5 * mouth_faps("MouthUpperUpLeft")
        + 0.3 * mouth_faps("MouthSmileRight")
        + 0.4 * mouth_faps("MouthLowerDownRight")
        + 0.6 * mouth_faps("MouthShrugLower")
    )
    got = avatar.posed(avatar.deform(faps))[0] / 0.001
    want = ref.posed(ref.deform(faps))[0]
    assert np.abs(got - want).max() < 0.05  # millimetres
    assert np.abs(want - ref.posed(ref.deform(np.zeros(68)))[0]).max() > 1.5


def test_the_demo_lips_open_an_avatars_mouth(exported_head):
    """The demo's lips (FAP 4, 5, 51, 52 = -40, no side FAPs) part the avatar's lips."""
    rig = AvatarRig(load_avatar(exported_head))
    faps = np.zeros(68)
    faps[[3, 4, 50, 51]] = -40.0
    moved = np.linalg.norm(rig.deform(faps).positions - rig.v0, axis=1) / 0.001
    face = builtin_face()
    upper, lower = face.fp_vertices["8.1"], face.fp_vertices["8.2"]
    assert moved[upper] > 0.5 and moved[lower] > 0.5  # mm
    gap = rig.deform(faps).positions[[upper, lower], 1] - rig.v0[[upper, lower], 1]
    assert gap[0] > 0 > gap[1]  # the upper lip up, the lower one down


def test_mouth_weights_invert_the_mouth_shapes():
    from renderer.lips import MOUTH_SHAPES, mouth_faps, mouth_weights

    for name in MOUTH_SHAPES:
        w = mouth_weights(0.3 * mouth_faps(name))
        # corners drawn in with the lips together read as a pucker (funnel = lips apart)
        expect = "MouthPucker" if name == "MouthFunnel" else name
        assert abs(float(w[expect]) - 0.3) < 1e-12, name
        assert all(abs(float(v)) < 1e-12 for k, v in w.items() if k != expect), name
    apart = (
        mouth_faps("MouthPucker")
        + mouth_faps("MouthUpperUpLeft")
        + mouth_faps("MouthUpperUpRight")
        + mouth_faps("MouthLowerDownLeft")
        + mouth_faps("MouthLowerDownRight")
    )
    w = mouth_weights(apart)
    assert float(w["MouthFunnel"]) == 1.0 and float(w["MouthPucker"]) == 0.0
    frames = np.zeros((3, 68))
    frames[1, [3, 4]] = -40.0
    assert mouth_weights(frames)["MouthLowerDownLeft"].tolist() == [0.0, 0.2, 0.0]
