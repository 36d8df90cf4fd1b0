"""FLAME's forward model: known answers, and a plain per-vertex loop written from the paper.

Every model here is built by the test (random bases of FLAME's documented shapes, or the
synthetic head of :mod:`tests.stimuli.meshes.synthetic`): FLAME itself is never used.
"""

import doctest
import io
import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.meshes import flame, pickles
from app.stimuli.meshes.flame import (
    FlameModel,
    FlameParams,
    flame_vertices,
    model_path,
    read_flame_model,
)
from app.stimuli.meshes.pickles import load_data_pickle
from tests.stimuli.meshes.synthetic import flame_like_model, head_mesh, write_flame_pkl


def test_doctests():
    assert doctest.testmod(flame).failed == 0
    assert doctest.testmod(pickles).failed == 0


def _rotation(v: list[float]) -> list[list[float]]:
    """Rodrigues' formula written out, without numpy."""
    angle = math.sqrt(sum(c * c for c in v))
    if angle == 0:
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    x, y, z = (c / angle for c in v)
    c, s, t = math.cos(angle), math.sin(angle), 1 - math.cos(angle)
    return [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]


def _mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def _apply(m, v):
    return [sum(m[i][k] * v[k] for k in range(3)) for i in range(3)]


def _loop_flame(model: FlameModel, shape, expression, pose) -> list[list[float]]:
    """One frame of FLAME (Li et al. 2017, eqs. 1-4) vertex by vertex: blendshapes, joints,
    pose correctives, then each vertex skinned by its weighted joint transforms."""
    n = model.n_vertices
    shaped = []
    for v in range(n):
        p = list(model.v_template[v])
        for k, b in enumerate(shape):
            p = [p[c] + model.shapedirs[v, c, k] * b for c in range(3)]
        for k, e in enumerate(expression):
            p = [p[c] + model.shapedirs[v, c, model.n_shape + k] * e for c in range(3)]
        shaped.append(p)
    joints = [
        [sum(model.j_regressor[j, v] * shaped[v][c] for v in range(n)) for c in range(3)]
        for j in range(5)
    ]
    rots = [_rotation(list(pose[j])) for j in range(5)]
    feature = [
        rots[j][a][b] - (1.0 if a == b else 0.0)
        for j in range(1, 5)
        for a in range(3)
        for b in range(3)
    ]
    world_r, world_t = [None] * 5, [None] * 5
    for j in range(5):
        parent = model.parents[j]
        if parent < 0:
            world_r[j], world_t[j] = rots[j], joints[j]
        else:
            local = [joints[j][c] - joints[parent][c] for c in range(3)]
            world_r[j] = _mul(world_r[parent], rots[j])
            moved = _apply(world_r[parent], local)
            world_t[j] = [world_t[parent][c] + moved[c] for c in range(3)]
    out = []
    for v in range(n):
        p = [
            shaped[v][c] + sum(model.posedirs[f, v * 3 + c] * feature[f] for f in range(36))
            for c in range(3)
        ]
        q = [0.0, 0.0, 0.0]
        for j in range(5):
            w = model.weights[v, j]
            moved = _apply(world_r[j], [p[c] - joints[j][c] for c in range(3)])
            q = [q[c] + w * (moved[c] + world_t[j][c]) for c in range(3)]
        out.append(q)
    return out


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 10_000))
def test_the_forward_pass_is_the_per_vertex_computation(seed):
    model = FlameModel.random(n_vertices=12, seed=seed, scale=0.01)
    rng = np.random.default_rng(seed)
    shape, expression = rng.normal(size=4), rng.normal(size=(2, 3))
    pose = rng.normal(0.0, 0.4, (2, 5, 3))
    out = flame_vertices(model, FlameParams(expression, pose, shape))
    for t in range(2):
        assert np.allclose(out[t], _loop_flame(model, shape, expression[t], pose[t]), atol=1e-10)


def test_zero_parameters_give_the_template():
    model = FlameModel.random(n_vertices=50, seed=3)
    assert np.allclose(flame_vertices(model, FlameParams.zeros(3)), model.v_template)


def test_pose_correctives_vanish_at_rest_and_shape_is_linear():
    model = FlameModel.random(n_vertices=40, seed=4)
    rest = FlameParams(np.zeros((1, 5)), np.zeros((1, 5, 3)), np.array([1.0, -2.0]))
    expected = model.v_template + model.shapedirs[:, :, 0] - 2.0 * model.shapedirs[:, :, 1]
    assert np.allclose(flame_vertices(model, rest)[0], expected)


def test_a_jaw_rotation_moves_only_the_jaw_by_the_rotation(tmp_path):
    head = head_mesh(16, 20)
    arrays = flame_like_model(head)
    arrays["posedirs"] = np.zeros_like(arrays["posedirs"])
    model = read_flame_model(_npz(arrays, tmp_path))
    pose = np.zeros((1, 5, 3))
    pose[0, 2, 0] = 0.3
    moved = flame_vertices(model, FlameParams(np.zeros((1, 0)), pose))[0]
    w = model.weights[:, 2]
    jaw = model.j_regressor[2] @ model.v_template
    rot = flame.rodrigues(np.array([0.3, 0.0, 0.0]))
    rotated = (model.v_template - jaw) @ rot.T + jaw
    still, full = w == 0, w == 1
    assert full.sum() > 50 and still.sum() > 400
    assert np.allclose(moved[still], model.v_template[still])
    assert np.allclose(moved[full], rotated[full])
    partial = ~still & ~full
    blend = (1 - w[partial, None]) * model.v_template[partial] + w[partial, None] * rotated[partial]
    assert np.allclose(moved[partial], blend)


def _npz(arrays, folder):
    path = folder / "model.npz"
    np.savez(path, **{k: v for k, v in arrays.items() if isinstance(v, np.ndarray)})
    return path


def test_flame_2020_pickles_with_chumpy_and_sparse_arrays_read_without_them(tmp_path):
    head = head_mesh(16, 20)
    arrays = flame_like_model(head)
    from_pkl = read_flame_model(write_flame_pkl(tmp_path / "generic_model.pkl", arrays))
    from_npz = read_flame_model(_npz(arrays, tmp_path))
    for a, b in (
        (from_pkl.shapedirs, arrays["shapedirs"]),
        (from_pkl.j_regressor, arrays["J_regressor"]),
        (from_pkl.posedirs, from_npz.posedirs),
    ):
        assert np.array_equal(a, b)
    assert from_pkl.parents.tolist() == [-1, 0, 1, 1, 1] and from_pkl.n_expression == 100


def test_model_files_of_another_structure_are_one_line(tmp_path):
    head = head_mesh(16, 20)
    arrays = flame_like_model(head)
    arrays["shapedirs"] = arrays["shapedirs"][:, :, :300]
    with pytest.raises(InputError, match="shapedirs has \\(300,\\) components"):
        read_flame_model(_npz(arrays, tmp_path))
    arrays = flame_like_model(head)
    arrays["weights"] = arrays["weights"][:, :4]
    with pytest.raises(InputError, match="weights has shape .*FLAME's is"):
        read_flame_model(_npz(arrays, tmp_path))
    (tmp_path / "x.pkl").write_bytes(pickle.dumps({"v_template": np.zeros((3, 3))}, protocol=2))
    with pytest.raises(InputError, match="x.pkl: not a FLAME model: no f, shapedirs"):
        read_flame_model(tmp_path / "x.pkl")


def test_no_model_file_is_refused_saying_what_is_needed(monkeypatch, tmp_path):
    monkeypatch.delenv(flame.MODEL_VARIABLE, raising=False)
    with pytest.raises(InputError) as err:
        model_path(None)
    assert "needs your own FLAME model file" in str(err.value)
    assert "FACEPAIR_FLAME_MODEL" in str(err.value) and "never ships or downloads" in str(err.value)
    monkeypatch.setenv(flame.MODEL_VARIABLE, str(tmp_path / "absent.pkl"))
    with pytest.raises(InputError, match="absent.pkl: no such FLAME model file"):
        model_path(None)


def test_the_pickle_reader_refuses_code_and_chumpy_expressions():
    class Evil:
        def __reduce__(self):
            return (print, ("boom",))

    with pytest.raises(InputError, match="refused to load __builtin__.print"):
        load_data_pickle(io.BytesIO(pickle.dumps(Evil(), protocol=2)), "evil.pkl")
    import sys
    import types

    class Ch:
        def __init__(self):
            self.a, self.b = 1, 2  # an expression: no stored x

    Ch.__module__, Ch.__qualname__ = "chumpy.ch", "Ch"
    module = types.ModuleType("chumpy.ch")
    module.Ch = Ch
    sys.modules["chumpy"], sys.modules["chumpy.ch"] = types.ModuleType("chumpy"), module
    try:
        blob = pickle.dumps({"shapedirs": Ch()}, protocol=2)
    finally:
        del sys.modules["chumpy.ch"], sys.modules["chumpy"]
    with pytest.raises(InputError, match="holds a chumpy expression"):
        load_data_pickle(io.BytesIO(blob), "m.pkl")


@settings(max_examples=60, deadline=None)
@given(st.binary(max_size=200))
def test_any_bytes_unpickle_to_data_or_fail_in_one_line(data):
    try:
        load_data_pickle(io.BytesIO(data), "x.pkl")
    except InputError as exc:
        assert str(exc).startswith("x.pkl: ") and "\n" not in str(exc)
