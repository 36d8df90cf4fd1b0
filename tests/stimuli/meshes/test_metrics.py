"""LVE and FDD on sequences with known answers, and as CodeTalker's evaluation computes them."""

import doctest

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.meshes import metrics
from app.stimuli.meshes.metrics import field_measures, lip_vertex_error, upper_face_dynamics


def test_doctests():
    assert doctest.testmod(metrics).failed == 0


def test_lve_is_the_largest_lip_error_per_frame_averaged():
    truth = np.zeros((4, 5, 3))
    pred = truth.copy()
    pred[0, 0, 0] = 0.001  # 1 mm on a lip
    pred[0, 1, 1] = 0.002  # 2 mm on a lip: the frame's largest
    pred[1, 4, 2] = 0.010  # 10 mm, but vertex 4 is no lip
    pred[2, 2, :] = [0.003, 0.004, 0.0]  # 5 mm
    lve = lip_vertex_error(pred, truth, np.array([0, 1, 2]))
    assert lve.mm == pytest.approx((2 + 0 + 5 + 0) / 4)
    assert lve.squared == pytest.approx((0.002**2 + 0.005**2) / 4)
    biwi = lip_vertex_error(pred, truth, np.array([0, 1, 2]), scale=0.2)  # in BIWI's units
    assert biwi.squared == pytest.approx(lve.squared / 0.04) and biwi.mm == lve.mm


def test_fdd_is_the_difference_of_the_upper_faces_motion_spread():
    template = np.zeros((3, 3))
    t = np.arange(6)
    truth = np.zeros((6, 3, 3))
    truth[:, 0, 1] = 0.002 * (t % 2)  # a brow going up and down by 2 mm: sd 1 mm
    pred = np.zeros((6, 3, 3))  # a still upper face
    fdd = upper_face_dynamics(pred, truth, template, np.array([0, 1]))
    assert fdd.mm == pytest.approx((1.0 + 0.0) / 2)  # averaged over the two upper vertices
    assert fdd.squared == pytest.approx(np.std(0.002**2 * (t % 2)) / 2)
    assert upper_face_dynamics(truth, truth, template, np.array([0, 1])).mm == 0.0
    assert upper_face_dynamics(truth, pred, template, np.array([0, 1])).mm < 0  # livelier


def _codetalker(pred, truth, template, mouth_map, upper_map):
    """The loops of Doubiiu/CodeTalker main/cal_metric.py, for one sequence, rewritten."""
    pred = pred[: truth.shape[0]]
    motion_pred, motion_gt = pred - template, truth - template
    upper_gt = np.mean(np.std(np.sum(np.square(motion_gt[:, upper_map]), axis=2), axis=0))
    upper_pred = np.mean(np.std(np.sum(np.square(motion_pred[:, upper_map]), axis=2), axis=0))
    lve = np.mean(
        np.max(np.sum(np.square(truth[:, mouth_map] - pred[:, mouth_map]), axis=2), axis=1)
    )
    return lve, upper_gt - upper_pred


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 9), st.integers(0, 3))
def test_the_squared_forms_are_codetalkers_numbers(seed, frames, extra):
    rng = np.random.default_rng(seed)
    template = rng.normal(size=(8, 3))
    truth = template + rng.normal(0, 0.01, (frames, 8, 3))
    pred = template + rng.normal(0, 0.01, (frames + extra, 8, 3))  # longer: cut to the truth
    lips, upper = np.array([0, 2, 3]), np.array([5, 6, 7])
    m = field_measures(pred, truth, template, lips, upper, scale=1.0)
    lve, fdd = _codetalker(pred, truth, template, lips, upper)
    assert m["lve_squared"] == pytest.approx(lve) and m["fdd_squared"] == pytest.approx(fdd)


def test_sequences_of_two_topologies_are_not_compared():
    with pytest.raises(InputError, match="not one topology"):
        lip_vertex_error(np.zeros((2, 4, 3)), np.zeros((2, 5, 3)), np.array([0]))
