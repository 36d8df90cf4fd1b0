"""FLAME parameter files in the layouts DiffPoseTalk, EMOTE, EMOCA and UniTalker write."""

import doctest
import json
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.meshes import flameparams
from app.stimuli.meshes.flameparams import (
    file_fps,
    params_from_arrays,
    read_param_mapping,
)


def test_doctests():
    assert doctest.testmod(flameparams).failed == 0


def _seq(t=4, width=3, start=0.0):
    return start + np.arange(t * width, dtype=float).reshape(t, width) / 100


def test_diffposetalk_npz_global_then_jaw(tmp_path):
    np.savez(tmp_path / "c.npz", exp=_seq(4, 50), pose=_seq(4, 6), shape=np.ones((4, 100)))
    p = params_from_arrays(read_param_mapping(tmp_path / "c.npz"), name="c.npz")
    assert np.array_equal(p.pose[:, 0], _seq(4, 6)[:, :3]) and np.array_equal(
        p.pose[:, 2], _seq(4, 6)[:, 3:]
    )
    assert not p.pose[:, [1, 3, 4]].any() and p.expression.shape == (4, 50)
    assert p.shape.shape == (4, 100)  # a shape per frame, as DiffPoseTalk repeats it


def test_emote_pickle_of_arrays(tmp_path):
    data = {
        "shape": np.zeros((4, 100)),
        "expression": _seq(4, 50),
        "jaw_pose": _seq(4, 3, 1.0),
        "global_pose": np.zeros((4, 3)),
    }
    (tmp_path / "flame_x.pkl").write_bytes(pickle.dumps(data, protocol=4))
    p = params_from_arrays(read_param_mapping(tmp_path / "flame_x.pkl"), name="flame_x.pkl")
    assert np.array_equal(p.pose[:, 2], data["jaw_pose"]) and not p.pose[:, 0].any()


def test_flame_names_neck_eyes_full_pose_and_json(tmp_path):
    data = {
        "expression_params": _seq(3, 10).tolist(),
        "neck_pose": _seq(3, 3).tolist(),
        "eye_pose": _seq(3, 6, 2.0).tolist(),
        "transl": np.ones((3, 3)).tolist(),
        "fps": 25,
    }
    (tmp_path / "p.json").write_text(json.dumps(data))
    mapping = read_param_mapping(tmp_path / "p.json")
    p = params_from_arrays(mapping, name="p.json")
    assert np.allclose(p.pose[:, 1], data["neck_pose"]) and np.allclose(
        p.pose[:, 4], np.array(data["eye_pose"])[:, 3:]
    )
    assert p.translation is not None and file_fps(mapping) == 25.0
    full = params_from_arrays({"expcode": _seq(3, 50), "full_pose": _seq(3, 15)}, name="f")
    assert np.allclose(full.pose.reshape(3, 15), _seq(3, 15))


def test_unitalker_vectors(tmp_path):
    a = np.zeros((5, 413))
    a[:, :300], a[:, 300:400], a[:, 400:403] = 1.0, 2.0, 0.25
    np.save(tmp_path / "u.npy", a)
    p = params_from_arrays(read_param_mapping(tmp_path / "u.npy"), name="u.npy")
    assert (p.shape == 1).all() and (p.expression == 2).all() and (p.pose[:, 2] == 0.25).all()
    with pytest.raises(InputError, match="u.npy: expected UniTalker's FLAME vectors"):
        params_from_arrays({"unitalker": np.zeros((5, 10))}, name="u.npy")


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"pose": np.zeros((3, 6))}, "c.npz: no FLAME expression (exp, expression"),
        ({"exp": np.zeros(3)}, "c.npz: exp has shape (3,), expected (T, E)"),
        ({"exp": np.zeros((3, 50)), "pose": np.zeros((3, 4))}, "c.npz: pose has shape (3, 4)"),
        ({"exp": np.zeros((3, 50)), "jaw_pose": np.zeros((2, 3))}, "c.npz: jaw pose has shape"),
        ({"exp": np.full((3, 50), np.nan)}, "c.npz: exp holds NaN or infinite values"),
    ],
)
def test_bad_parameters_are_one_line(data, message):
    with pytest.raises(InputError) as err:
        params_from_arrays(data, name="c.npz")
    assert str(err.value).startswith(message)


keys = st.sampled_from(["exp", "expression", "pose", "jaw_pose", "shape", "eye_pose", "x"])
values = st.one_of(
    st.integers(0, 4).flatmap(
        lambda t: st.lists(
            st.lists(st.floats(-2, 2) | st.just(float("nan")), max_size=7), min_size=t, max_size=t
        )
    ),
    st.floats(allow_nan=True),
    st.text(max_size=3),
)


@settings(max_examples=100, deadline=None)
@given(st.dictionaries(keys, values, max_size=5))
def test_any_mapping_gives_parameters_or_one_line(data):
    try:
        p = params_from_arrays(data, name="c.npz")
    except InputError as exc:
        assert str(exc).startswith("c.npz: ") and "\n" not in str(exc)
    else:
        assert p.pose.shape == (p.n_frames, 5, 3) and np.isfinite(p.pose).all()
