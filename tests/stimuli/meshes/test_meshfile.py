"""Template meshes in OBJ and PLY, as the projects' templates are written."""

import doctest
import io

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.meshes import meshfile
from app.stimuli.meshes.meshfile import read_mesh, write_obj, write_ply


def test_doctests():
    assert doctest.testmod(meshfile).failed == 0


def _grid(n: int = 4):
    v = np.array([[x, y, 0.0] for y in range(n) for x in range(n)], dtype=np.float64) * 0.01
    t = []
    for y in range(n - 1):
        for x in range(n - 1):
            a = y * n + x
            t += [(a, a + 1, a + n), (a + 1, a + n + 1, a + n)]
    return v, np.array(t, dtype=np.int32)


def test_biwi_layout_binary_ply_and_obj_read_back(tmp_path):
    v, t = _grid()
    ply = read_mesh(write_ply(tmp_path / "BIWI.ply", v, t))
    obj = read_mesh(write_obj(tmp_path / "FLAME_sample.obj", v, t))
    for mesh in (ply, obj):
        assert np.allclose(mesh.vertices, v, atol=1e-7) and np.array_equal(mesh.triangles, t)


def test_ascii_and_big_endian_ply_with_other_properties_and_quads():
    text = (
        "ply\nformat ascii 1.0\ncomment x\nelement vertex 4\nproperty double x\n"
        "property double y\nproperty double z\nproperty uchar red\nelement face 1\n"
        "property list uchar uint vertex_index\nend_header\n"
        "0 0 0 255\n1 0 0 255\n1 1 0 255\n0 1 0 255\n4 0 1 2 3\n"
    )
    mesh = read_mesh(io.BytesIO(text.encode()), "quad.ply")
    assert mesh.triangles.tolist() == [[0, 1, 2], [0, 2, 3]]
    v = np.arange(9, dtype=">f4").reshape(3, 3)
    faces = np.zeros(1, dtype=[("n", "u1"), ("i", ">i4", (3,))])
    faces["n"], faces["i"] = 3, [0, 1, 2]
    header = (
        "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    mesh = read_mesh(io.BytesIO(header.encode() + v.tobytes() + faces.tobytes()), "be.ply")
    assert np.allclose(mesh.vertices, v.astype(float))


def test_obj_corners_with_texture_and_normal_indices_and_negative_indices():
    text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1/1 2//1 -1\n"
    assert read_mesh(io.StringIO(text), "a.obj").triangles.tolist() == [[0, 1, 2]]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("v 0 0\n", "a.obj:1: expected 'v x y z'"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "a.obj: a face names vertex 9 of 3"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "a.obj: the template has no faces (triangles)"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "a.obj:4: face corner 0: OBJ counts from 1"),
        ("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "a.obj: the template has a vertex that"),
        ("hello\n", "a.obj: no 'v' lines: not an OBJ mesh"),
    ],
)
def test_bad_obj_files_are_one_line_naming_the_file(text, message):
    with pytest.raises(InputError) as err:
        read_mesh(io.StringIO(text), "a.obj")
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


def test_a_truncated_binary_ply_is_one_line(tmp_path):
    v, t = _grid()
    path = write_ply(tmp_path / "t.ply", v, t)
    path.write_bytes(path.read_bytes()[:-20])
    with pytest.raises(InputError, match="ends early"):
        read_mesh(path)


@settings(max_examples=60, deadline=None)
@given(st.binary(max_size=300), st.sampled_from(["a.obj", "a.ply"]))
def test_any_bytes_read_or_fail_in_one_line(data, name):
    """The reader never fails with anything but one :class:`InputError` line."""
    try:
        mesh = read_mesh(io.BytesIO(data), name)
    except InputError as exc:
        assert "\n" not in str(exc)
    else:
        assert mesh.triangles.max() < len(mesh.vertices)


@settings(max_examples=30, deadline=None)
@given(
    st.integers(3, 40).flatmap(
        lambda n: st.tuples(
            st.lists(st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3), min_size=n, max_size=n),
            st.lists(st.tuples(*[st.integers(0, n - 1)] * 3), min_size=1, max_size=50),
        )
    )
)
def test_written_meshes_read_back(tmp_path_factory, mesh):
    vertices, triangles = (np.array(x) for x in mesh)
    folder = tmp_path_factory.mktemp("m")
    for writer, name in ((write_obj, "m.obj"), (write_ply, "m.ply")):
        back = read_mesh(writer(folder / name, vertices, triangles))
        assert np.array_equal(back.triangles, triangles)
        assert np.allclose(back.vertices, vertices, atol=1e-6)
