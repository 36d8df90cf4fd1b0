"""The built-in head as a glTF avatar: it opens as glTF, and renders as the built-in head."""

import imageio.v3 as iio
import numpy as np
import pygltflib
import pytest
from click.testing import CliRunner

from app.cli import main
from app.stimuli.track import MotionTrack
from renderer import RenderSettings, render_still
from renderer.headmodel import builtin_face


def _psnr(a, b) -> float:
    mse = np.mean((iio.imread(a).astype(float) - iio.imread(b).astype(float)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(255.0**2 / mse)


@pytest.mark.parametrize("mosaic", [False, True])
def test_exported_head_renders_as_the_builtin_one(exported_head, tmp_path, mosaic):
    channels = {48: np.full(3, -6000.0), 49: np.full(3, 15000.0), 50: np.full(3, 4000.0)}
    channels.update({f: np.full(3, 80.0) for f in range(31, 37)})  # raised brows
    track = MotionTrack.from_channels(30.0, channels)
    a = render_still(
        track, 1, tmp_path / "builtin.png", settings=RenderSettings(size=192), mosaic=mosaic
    )
    b = render_still(
        track,
        1,
        tmp_path / "avatar.png",
        mosaic=mosaic,
        settings=RenderSettings(size=192, face=str(exported_head)),
    )
    assert _psnr(a, b) >= 35.0
    rest = render_still(
        MotionTrack.from_channels(30.0, {49: np.zeros(3)}),
        1,
        tmp_path / "rest.png",
        settings=RenderSettings(size=192),
        mosaic=mosaic,
    )
    assert _psnr(rest, b) < 30.0  # the comparison sees head turns and brows


def test_export_is_glTF_with_arkit_morph_targets_and_humanoid_bones(exported_head):
    gltf = pygltflib.GLTF2().load_binary(str(exported_head))
    assert gltf.asset.version == "2.0"
    mesh = gltf.meshes[0]
    names = mesh.extras["targetNames"]
    # ARKit's own spelling (Apple's ARFaceAnchor.BlendShapeLocation), not Live Link Face's
    assert {"jawOpen", "browInnerUp", "eyeBlinkLeft", "browOuterUpRight"} <= set(names)
    mouth = {"mouthClose", "mouthFunnel", "mouthPucker", "mouthRollLower", "mouthUpperUpLeft"}
    assert mouth <= set(names)
    assert all(n[0].islower() for n in names)
    assert len(names) == len(mesh.primitives[0].targets) == len(mesh.weights)
    joints = [gltf.nodes[j].name for j in gltf.skins[0].joints]
    assert {"head", "leftEye", "rightEye"} <= set(joints)
    # metres, as glTF asks: a head is a few tenths of a metre tall
    lo, hi = (np.array(x) for x in (gltf.accessors[0].min, gltf.accessors[0].max))
    assert 0.2 < (hi - lo)[1] < 0.8


def test_jaw_open_target_is_the_builtin_jaw_at_the_mapped_fap(exported_head):
    """JawOpen at 1 is FAP 3 = 800 (the ARKit table): the built-in jaw opened that far."""
    from renderer.avatar import load_avatar
    from renderer.deform import Rig

    face, ref = load_avatar(exported_head), builtin_face()
    faps = np.zeros(68)
    faps[3 - 1] = 800.0
    want = (Rig(ref).deform(faps).positions - ref.vertices) * 0.001
    got = face.targets["JawOpen"][0]
    assert np.abs(got - want).max() < 1e-6
    assert np.linalg.norm(got[ref.fp_vertices["2.1"]]) > 0.02  # the chin moves centimetres
    assert not got[ref.fp_vertices["4.1"]].any()  # the brows do not


def test_face_export_command(tmp_path):
    runner = CliRunner()
    result = runner.invoke(main, ["face", "export", "--out", str(tmp_path / "h.glb")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "h.glb").stat().st_size > 100_000
    bad = runner.invoke(main, ["face", "export", "--out", str(tmp_path / "h.obj")])
    assert bad.exit_code == 2 and "*.glb" in bad.output and "Traceback" not in bad.output
