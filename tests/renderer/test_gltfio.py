"""Reading glTF: VRM orientation and humanoid bones, compressed files, .gltf with embedded data
(the textures: tests/renderer/test_gltfmaterial.py)."""

from pathlib import Path

import numpy as np
import pygltflib
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from renderer.avatar import load_avatar
from renderer.gltfio import read_gltf


def _edited(exported_head, path, edit):
    gltf = pygltflib.GLTF2().load_binary(str(exported_head))
    edit(gltf)
    gltf.save_binary(str(path))
    return path


def test_vrm0_avatar_faces_the_camera_and_names_its_bones(exported_head, tmp_path):
    """A VRM 0.x avatar faces -z with its humanoid bones in the VRM extension: it is turned
    half round and its bones are found under any node names."""

    def to_vrm0(gltf):
        bones = []
        for node_index, node in enumerate(gltf.nodes):
            if node.name in ("head", "leftEye", "rightEye"):
                bones.append({"bone": node.name, "node": node_index})
                node.name = f"bone{node_index}"
        gltf.extensions = {"VRM": {"humanoid": {"humanBones": bones}}}
        gltf.extensionsUsed = ["VRM"]
        # face -z, as VRM 0.x avatars do: turn the mesh and the bones half round
        blob = bytearray(gltf.binary_blob())
        for acc_index in [0, 1] + [
            a for t in gltf.meshes[0].primitives[0].targets for a in t.values()
        ]:
            acc = gltf.accessors[acc_index]
            view = gltf.bufferViews[acc.bufferView]
            data = np.frombuffer(blob, np.float32, acc.count * 3, view.byteOffset).copy()
            data = (data.reshape(-1, 3) * (-1.0, 1.0, -1.0)).astype(np.float32)
            blob[view.byteOffset : view.byteOffset + data.nbytes] = data.tobytes()
        for node in gltf.nodes:
            if node.translation:
                node.translation = [-node.translation[0], node.translation[1], -node.translation[2]]
        # the inverse bind matrices turn with the bones (F M F, F = diag(-1, 1, -1, 1))
        acc = gltf.accessors[gltf.skins[0].inverseBindMatrices]
        at = gltf.bufferViews[acc.bufferView].byteOffset + (acc.byteOffset or 0)
        ibm = np.frombuffer(blob, np.float32, acc.count * 16, at).reshape(-1, 4, 4)
        turn = np.diag([-1.0, 1.0, -1.0, 1.0]).astype(np.float32)
        blob[at : at + ibm.nbytes] = (turn @ ibm @ turn).astype(np.float32).tobytes()
        gltf.set_binary_blob(bytes(blob))
        gltf.extras = {}

    vrm = _edited(exported_head, tmp_path / "a.vrm", to_vrm0)
    turned, plain = load_avatar(vrm), load_avatar(exported_head)
    assert np.allclose(turned.vertices, plain.vertices, atol=1e-6)
    assert np.allclose(turned.eye_pivots["l"], plain.eye_pivots["l"], atol=1e-6)
    assert turned.eye_pivots["l"][0] > 0  # the left eye on the face's left, +x


def test_gltf_with_embedded_buffers_reads_as_the_glb(exported_head, tmp_path):
    gltf = pygltflib.GLTF2().load_binary(str(exported_head))
    gltf.convert_buffers(pygltflib.BufferFormat.DATAURI)
    path = tmp_path / "head.gltf"
    gltf.save_json(str(path))
    a, b = read_gltf(path), read_gltf(exported_head)
    assert np.array_equal(a.vertices, b.vertices) and sorted(a.targets) == sorted(b.targets)


def test_a_scene_without_triangles_is_an_input_error(tmp_path):
    path = tmp_path / "empty.gltf"
    pygltflib.GLTF2(
        asset=pygltflib.Asset(version="2.0"),
        nodes=[pygltflib.Node()],
        scenes=[pygltflib.Scene(nodes=[0])],
    ).save_json(str(path))
    with pytest.raises(InputError, match="no triangle mesh"):
        read_gltf(path)


def _tiny_gltf() -> dict:
    """A one-triangle skinned glTF with one morph target, as JSON with embedded buffers."""
    import json
    import tempfile
    from pathlib import Path

    from renderer.gltfwrite import MeshOut, write_glb

    v = np.eye(3)
    with tempfile.TemporaryDirectory() as d:
        path = write_glb(
            Path(d) / "t.glb",
            MeshOut(
                v,
                np.tile([0, 0, 1.0], (3, 1)),
                np.array([[0, 1, 2]]),
                np.ones((3, 4)),
                {"JawOpen": (v * 0.1, v * 0)},
                joints=np.zeros((3, 4), np.uint8),
                weights=np.tile([1.0, 0, 0, 0], (3, 1)),
            ),
            bones=[("head", -1, np.zeros(3))],
            extras={},
        )
        gltf = pygltflib.GLTF2().load_binary(str(path))
    gltf.convert_buffers(pygltflib.BufferFormat.DATAURI)
    return json.loads(gltf.to_json())


TINY = _tiny_gltf()
_INT_FIELDS = [
    ("nodes", "mesh"),
    ("nodes", "skin"),
    ("accessors", "count"),
    ("accessors", "bufferView"),
    ("accessors", "byteOffset"),
    ("accessors", "componentType"),
    ("bufferViews", "byteOffset"),
    ("bufferViews", "byteLength"),
    ("bufferViews", "byteStride"),
    ("skins", "inverseBindMatrices"),
    ("scenes", "nodes"),
]


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    edits=st.lists(
        st.tuples(
            st.sampled_from(_INT_FIELDS), st.integers(0, 5), st.integers(-3, 10**6) | st.just(None)
        ),
        min_size=1,
        max_size=3,
    )
)
def test_a_corrupted_gltf_reads_or_is_an_input_error(tmp_path, edits):
    import copy
    import json

    doc = copy.deepcopy(TINY)
    for (array, key), index, value in edits:
        items = doc.get(array) or []
        if items:
            items[index % len(items)][key] = [value] if key == "nodes" else value
    path = tmp_path / "c.gltf"
    path.write_text(json.dumps(doc))
    try:
        read_gltf(path)
    except InputError as err:
        assert "\n" not in str(err)


# Compressed avatars as they are delivered (files made by tests/renderer/data/
# make_compressed_avatars.py with gltfpack 1.3, glTF-Transform 4.5 and basisu 1.16).
DATA = Path(__file__).parent / "data"
COMPRESSED = ["head-gltfpack.glb", "head-draco.glb", "head-ktx2.glb"]


def _matched(ref, scene):
    """Each vertex of ``scene`` paired with the export's vertex it came from: the nearest in
    position, ties (lips and eyelids that meet, UV seams) broken by targets, normals and UVs."""
    from scipy.spatial import cKDTree

    names = sorted(ref.targets)
    r = np.concatenate([ref.targets[k][0] for k in names], axis=1)
    s = np.concatenate([scene.targets[k][0] for k in names], axis=1)
    # k covers the crown pole, one vertex per texture column (renderer/uvseam.py)
    dist, idx = cKDTree(ref.vertices).query(scene.vertices, k=96)
    cost = (
        np.abs(s[:, None] - r[idx]).max(axis=2)
        + np.abs(scene.normals[:, None] - ref.normals[idx]).max(axis=2)
        + np.abs(scene.uvs[:, None] - ref.uvs[idx]).max(axis=2)
        + 1e3 * (dist > 1e-4)
    )
    return idx[np.arange(len(idx)), cost.argmin(axis=1)], r, s


@pytest.mark.parametrize("name", COMPRESSED)
def test_compressed_avatar_reads_as_the_exported_head(exported_head, name):
    ref, scene = read_gltf(exported_head), read_gltf(DATA / name)
    assert sorted(scene.targets) == sorted(ref.targets) and len(scene.targets) == 27
    best, r, s = _matched(ref, scene)
    assert len(np.unique(best)) > 0.95 * len(ref.vertices)  # exact duplicates pair alike
    # 14-bit positions over a 0.5 m head: a step of 30 um; the morph deltas alike
    assert np.abs(scene.vertices - ref.vertices[best]).max() < 4e-5
    assert np.abs(s - r[best]).max() < 4e-5
    assert np.abs(scene.uvs - ref.uvs[best]).max() < 2e-4  # 12-bit UVs
    assert np.median(np.abs(scene.normals - ref.normals[best]).max(axis=1)) < 0.02
    face = load_avatar(DATA / name)
    assert {"JawOpen", "MouthClose", "MouthUpperUpLeft"} <= set(face.targets)


def test_ktx2_texture_is_transcoded_as_the_png_it_was_made_from():
    png, ktx2 = read_gltf(DATA / "head-gltfpack.glb"), read_gltf(DATA / "head-ktx2.glb")
    assert ktx2.texture is not None and ktx2.texture.shape == png.texture.shape == (64, 64, 3)
    # ETC1S is lossy: a few levels of 255 on average
    assert np.abs(ktx2.texture.astype(float) - png.texture).mean() < 8


def _requiring(src, path, extension):
    gltf = pygltflib.GLTF2().load_binary(str(src))
    gltf.extensionsRequired = [*(gltf.extensionsRequired or []), extension]
    gltf.extensionsUsed = [*(gltf.extensionsUsed or []), extension]
    gltf.save_binary(str(path))
    return path


@pytest.mark.parametrize(
    "extension,command",
    [
        ("EXT_texture_avif", "gltf-transform png in.glb out.glb"),
        ("KHR_materials_variants", "gltfpack -i in.glb -o out.glb -noq"),
    ],
)
def test_an_unread_required_extension_is_named_with_its_conversion(tmp_path, extension, command):
    path = _requiring(DATA / "head-gltfpack.glb", tmp_path / "a.glb", extension)
    with pytest.raises(InputError) as err:
        read_gltf(path)
    message = str(err.value)
    assert "\n" not in message and message.startswith(str(path))
    assert f"requires the glTF extension {extension}" in message and command in message


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    name=st.sampled_from(COMPRESSED),
    flips=st.lists(st.tuples(st.floats(0, 1), st.integers(1, 255)), min_size=1, max_size=8),
)
def test_corrupted_compressed_data_reads_or_is_an_input_error(tmp_path, name, flips):
    """Bytes flipped anywhere in the binary chunk (meshopt streams, Draco data, KTX2)."""
    data = bytearray((DATA / name).read_bytes())
    json_len = int.from_bytes(data[12:16], "little")
    start = 20 + json_len + 8
    for where, xor in flips:
        data[start + int(where * (len(data) - start - 1))] ^= xor
    path = tmp_path / "c.glb"
    path.write_bytes(bytes(data))
    try:
        read_gltf(path)
    except InputError as err:
        assert "\n" not in str(err)


@pytest.mark.parametrize("codec,tolerance", [("etc1s", 4.0), ("uastc", 1.0)])
def test_ktx2_codecs_transcode_to_known_pixels(codec, tolerance):
    from renderer.gltfdecode import decode_ktx2

    y, x = np.mgrid[:16, :16]
    odd = ((x // 4 + y // 4) % 2).astype(bool)
    want = np.where(odd[..., None], [200, 40, 40], [40, 60, 200])
    got = decode_ktx2((DATA / f"checker-{codec}.ktx2").read_bytes())
    assert got.shape == (16, 16, 4)
    assert np.abs(got[..., :3] - want).max() <= tolerance


def test_a_meshopt_view_claiming_more_than_it_can_hold_is_refused(tmp_path):
    gltf = pygltflib.GLTF2().load_binary(str(DATA / "head-gltfpack.glb"))
    view = next(v for v in gltf.bufferViews if v.extensions.get("EXT_meshopt_compression"))
    view.extensions["EXT_meshopt_compression"]["count"] = 2**28  # 4 GB of 16-byte vertices
    gltf.save_binary(str(tmp_path / "a.glb"))
    with pytest.raises(InputError, match="cannot come from"):
        read_gltf(tmp_path / "a.glb")


_JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-3, 5) | st.floats(-2, 200) | st.text(max_size=6),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner, max_size=3)
    ),
    max_leaves=12,
)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    version=st.sampled_from(["VRM", "VRMC_vrm"]),
    binds=st.lists(
        st.fixed_dictionaries({"mesh": _JSON, "node": _JSON, "index": _JSON, "weight": _JSON}),
        max_size=3,
    ),
    name=st.text(max_size=10),
    junk=_JSON,
)
def test_any_vrm_expressions_read_or_are_an_input_error(tmp_path, version, binds, name, junk):
    import copy
    import json

    doc = copy.deepcopy(TINY)
    if version == "VRM":
        groups = [{"name": name, "presetName": "unknown", "binds": binds}, junk]
        doc["extensions"] = {"VRM": {"blendShapeMaster": {"blendShapeGroups": groups}}}
    else:
        expr = {"preset": {name: {"morphTargetBinds": binds}}, "custom": junk}
        doc["extensions"] = {"VRMC_vrm": {"expressions": expr}}
    path = tmp_path / "v.gltf"
    path.write_text(json.dumps(doc))
    try:
        scene = read_gltf(path)
    except InputError as err:
        assert "\n" not in str(err)
    else:
        assert all(np.isfinite(dp).all() for dp, _ in scene.expressions.values())
