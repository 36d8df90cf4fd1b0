"""Bring-your-own faces: a round trip of the built-in head, and clear errors for bad files."""

import json

import numpy as np
import pytest

from app.errors import InputError
from renderer.deform import Rig
from renderer.headmodel import builtin_face
from renderer.objface import load_face, read_obj, write_face


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    path = tmp_path_factory.mktemp("face") / "head.json"
    write_face(builtin_face(), path)
    return path


def test_round_trip_keeps_mesh_points_fapu_and_rig(exported):
    face = load_face(exported)
    ref = builtin_face()
    assert face.n_vertices == ref.n_vertices and face.n_triangles == ref.n_triangles
    assert np.allclose(face.vertices, ref.vertices, atol=1e-4)
    for k in ref.fapu:
        assert face.fapu[k] == pytest.approx(ref.fapu[k])
    assert face.fp_vertices == ref.fp_vertices
    assert np.array_equal(face.groups["hidden_outline"], ref.groups["hidden_outline"])
    faps = np.zeros(68)
    faps[2] = 300.0  # open the jaw: the exported weights part the lips as before
    a, b = Rig(face).deform(faps), Rig(ref).deform(faps)
    assert np.allclose(a.positions, b.positions, atol=1e-3)


def _spec(exported, **changes):
    spec = json.loads(exported.read_text())
    spec["mesh"] = str(exported.with_suffix(".obj"))
    spec.update(changes)
    return spec


def _write(tmp_path, spec):
    p = tmp_path / "face.json"
    p.write_text(json.dumps(spec))
    return p


def test_missing_feature_points_are_named(exported, tmp_path):
    spec = _spec(exported)
    del spec["feature_points"]["2.1"], spec["feature_points"]["4.3"]
    with pytest.raises(
        InputError,
        match=r"face.json: feature_points: missing feature points: "
        r"2.1, 4.3",
    ):
        load_face(_write(tmp_path, spec))


def test_out_of_range_vertex_and_missing_group(exported, tmp_path):
    spec = _spec(exported)
    spec["feature_points"]["2.2"] = 10**9
    with pytest.raises(InputError, match=r"feature_points.2.2: vertex index 1000000000 out"):
        load_face(_write(tmp_path, spec))
    spec = _spec(exported)
    del spec["groups"]["eyeball_r"]
    with pytest.raises(InputError, match=r"groups.eyeball_r: missing group"):
        load_face(_write(tmp_path, spec))
    spec = _spec(exported)
    spec["groups"]["hidden_outline"] = [0, -1]
    with pytest.raises(InputError, match=r"groups.hidden_outline: vertex index out of range"):
        load_face(_write(tmp_path, spec))
    spec = _spec(exported)
    del spec["groups"]["hidden_outline"]  # optional: without it every outline is overdrawn
    assert "hidden_outline" not in load_face(_write(tmp_path, spec)).groups


def test_mouth_points_must_be_vertices_and_fapu_positive(exported, tmp_path):
    spec = _spec(exported)
    spec["feature_points"]["8.1"] = [0.0, 1.0, 2.0]
    with pytest.raises(InputError, match="mouth points must be vertex indices: 8.1"):
        load_face(_write(tmp_path, spec))
    spec = _spec(exported, fapu={"ES0": -3})
    with pytest.raises(InputError, match=r"fapu.ES0: must be a positive number"):
        load_face(_write(tmp_path, spec))


def test_bad_json_and_missing_mesh(tmp_path):
    p = tmp_path / "face.json"
    p.write_text('{"mesh": "x.obj",\n "feature_points": {,}}')
    with pytest.raises(InputError, match=r"face.json:2: not valid JSON"):
        load_face(p)
    p.write_text('{"mesh": "nowhere.obj"}')
    with pytest.raises(InputError, match=r"nowhere.obj: mesh file not found"):
        load_face(p)
    with pytest.raises(InputError, match="face file not found"):
        load_face(tmp_path / "absent.json")


@pytest.mark.parametrize(
    "text, message",
    [
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", r"bad.obj:4: face refers to vertex 9"),
        ("v 0 0 zero\n", r"bad.obj:1: vertex coordinates must be numbers"),
        ("v 0 0 0\nv 1 0 0\nf 1 2\n", r"bad.obj:3: a face needs at least 3 vertices"),
        ("v 0 0 0\n", r"bad.obj: no triangles"),
    ],
)
def test_bad_obj_lines_are_reported_with_their_line(tmp_path, text, message):
    p = tmp_path / "bad.obj"
    p.write_text(text)
    with pytest.raises(InputError, match=message):
        read_obj(p)


def test_obj_polygons_become_fans_and_relative_indices_resolve(tmp_path):
    p = tmp_path / "quad.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1/1 2/2/2 3/3/3 -1\n")
    v, t, rgb = read_obj(p)
    assert v.shape == (4, 3) and t.tolist() == [[0, 1, 2], [0, 2, 3]] and rgb is None
