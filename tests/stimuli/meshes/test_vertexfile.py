"""Vertex sequences: FaceFormer's (T, 3V), SelfTalk's (T, V, 3), units, and bad input in one
line."""

import doctest

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from app.errors import InputError
from app.stimuli.meshes import vertexfile
from app.stimuli.meshes.vertexfile import (
    detect_units,
    load_array,
    read_pose_array,
    read_vertex_array,
    rodrigues,
)


def test_doctests():
    assert doctest.testmod(vertexfile).failed == 0


def test_flat_and_stacked_layouts_are_the_same_frames():
    frames = np.random.default_rng(0).normal(size=(5, 7, 3))
    flat = read_vertex_array(frames.reshape(5, 21), n_vertices=7, name="ff.npy")
    stacked = read_vertex_array(frames, n_vertices=7, name="st.npy")
    assert np.array_equal(flat, stacked) and flat.dtype == np.float32


@pytest.mark.parametrize(
    ("array", "message"),
    [
        (np.zeros((4, 9)), "face.npy: 3 vertices per frame, but the template has 5"),
        (np.zeros((4, 5, 2)), "face.npy: expected frames of shape (T, V, 3) or (T, 3V)"),
        (np.zeros((0, 15)), "face.npy: no frames"),
        (np.array(["a"]), "face.npy: expected numbers"),
    ],
)
def test_bad_arrays_are_one_line(array, message):
    with pytest.raises(InputError) as err:
        read_vertex_array(array, n_vertices=5, name="face.npy")
    assert str(err.value).startswith(message)


def test_nan_frames_are_counted_and_the_first_named():
    a = np.zeros((6, 5, 3))
    a[2, 4, 1] = np.nan
    a[5, 0, 0] = np.inf
    with pytest.raises(InputError) as err:
        read_vertex_array(a, n_vertices=5, name="face.npy")
    assert str(err.value) == (
        "face.npy: 2 frame(s) hold NaN or infinite values (first: frame 2, vertex 4)"
    )


def test_npz_arrays_by_key_or_alone_and_pickles_refused(tmp_path):
    frames = np.ones((2, 6))
    np.savez(tmp_path / "a.npz", vertices=frames, audio=np.zeros(10))
    np.savez(tmp_path / "b.npz", whatever=frames)
    np.savez(tmp_path / "c.npz", one=frames, two=frames)
    assert load_array(tmp_path / "a.npz").shape == (2, 6)
    assert load_array(tmp_path / "b.npz").shape == (2, 6)
    with pytest.raises(InputError, match="c.npz: expected one vertex array"):
        load_array(tmp_path / "c.npz")
    np.save(tmp_path / "u.npy", np.array([{"D1": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(InputError, match="u.npy: holds pickled objects"):
        load_array(tmp_path / "u.npy")
    with pytest.raises(InputError, match="gone.npy: no such vertex file"):
        load_array(tmp_path / "gone.npy")
    (tmp_path / "bad.npy").write_bytes(b"not numpy")
    with pytest.raises(InputError, match="bad.npy: not a"):
        load_array(tmp_path / "bad.npy")


def test_units_from_the_heads_width():
    head = np.array([[-0.078, 0.0, 0.0], [0.078, 0.2, 0.1]])  # a 15.6 cm wide head
    assert detect_units(head, name="t") == "m"
    assert detect_units(head * 1000, name="t") == "mm"
    assert detect_units(head * 100, name="t") == "cm"
    biwi = np.zeros((23370, 3))
    biwi[:2] = head / 0.2  # BIWI.ply is 0.77 units wide
    assert detect_units(biwi, name="BIWI.ply") == "biwi"
    with pytest.raises(InputError) as err:
        detect_units(head * 10, name="t.obj")
    assert str(err.value).startswith("t.obj: units implausible: the template is 1.56 units wide")
    with pytest.raises(InputError, match="units implausible: in mm the template is 0.000156 m"):
        detect_units(head, name="t.obj", declared="mm")
    with pytest.raises(InputError, match="unknown units 'inch'"):
        detect_units(head, name="t.obj", declared="inch")


def test_poses_as_axis_angle_with_translation_or_matrices():
    aa = np.array([[0.0, 0.3, 0.0], [0.1, 0.0, 0.0]])
    rot = read_pose_array(aa, 2, name="p.npy")
    c, s = np.cos(0.3), np.sin(0.3)
    assert np.allclose(rot[0], [[c, 0, s], [0, 1, 0], [-s, 0, c]])  # a turn about +y
    assert np.allclose(read_pose_array(np.hstack([aa, np.ones((2, 3))]), 2, name="p"), rot)
    assert np.allclose(read_pose_array(rot, 2, name="p"), rot)
    with pytest.raises(InputError, match="p.npy: 2 poses for 3 frames"):
        read_pose_array(aa, 3, name="p.npy")


@settings(max_examples=50, deadline=None)
@given(arrays(np.float64, st.integers(1, 3), elements=st.floats(-3, 3)))
def test_rodrigues_gives_rotations(vector):
    r = rodrigues(np.resize(vector, 3))
    assert np.allclose(r @ r.T, np.eye(3), atol=1e-9) and np.isclose(np.linalg.det(r), 1.0)


@settings(max_examples=80, deadline=None)
@given(
    arrays(
        st.sampled_from([np.float32, np.float64]),
        st.tuples(st.integers(0, 4), st.integers(0, 12), st.integers(1, 4)).map(
            lambda s: s if s[2] != 4 else s[:2]
        ),
        elements=st.floats(allow_nan=True, allow_infinity=True, width=16),
    )
    | arrays(np.int16, st.tuples(st.integers(0, 4), st.integers(0, 12))),
    st.integers(1, 6),
)
def test_any_array_reads_or_fails_in_one_line(array, n_vertices):
    try:
        frames = read_vertex_array(array, n_vertices=n_vertices, name="x.npy")
    except InputError as exc:
        assert str(exc).startswith("x.npy: ") and "\n" not in str(exc)
    else:
        assert frames.shape[1:] == (n_vertices, 3) and np.isfinite(frames).all()
