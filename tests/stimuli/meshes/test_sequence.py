"""The mesh sequence's timeline, head turns as FAPs, stabilising, and the bundle."""

import doctest

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from app.stimuli.fap import HEAD_PITCH, HEAD_ROLL, HEAD_YAW
from app.stimuli.meshes import sequence
from app.stimuli.meshes.sequence import (
    MeshSequence,
    read_bundle,
    rigid_fit,
    rotation_to_gaze_faps,
    rotation_to_head_faps,
    sample,
    stabilise,
    write_bundle,
)
from app.stimuli.meshes.vertexfile import rodrigues
from renderer.deform import EYE_TURNS, HEAD_TURNS, fap_rotation
from tests.stimuli.meshes.synthetic import head_mesh, talking

angles = st.floats(-0.6, 0.6)


def test_doctests():
    assert doctest.testmod(sequence).failed == 0


@settings(max_examples=60, deadline=None)
@given(angles, angles, angles)
def test_head_faps_are_the_rotation_the_renderer_turns(pitch, yaw, roll):
    faps = np.zeros(68)
    faps[[HEAD_PITCH - 1, HEAD_YAW - 1, HEAD_ROLL - 1]] = np.array([pitch, yaw, roll]) / 1e-5
    rot = fap_rotation(faps, HEAD_TURNS)
    back = np.zeros(68)
    back[[HEAD_PITCH - 1, HEAD_YAW - 1, HEAD_ROLL - 1]] = rotation_to_head_faps(rot[None])[0]
    assert np.allclose(fap_rotation(back, HEAD_TURNS), rot, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(angles, angles)
def test_gaze_faps_are_the_eyes_turn(yaw, pitch):
    faps = np.zeros(68)
    turns = EYE_TURNS["l"]
    faps[turns[0] - 1], faps[turns[1] - 1] = yaw / 1e-5, pitch / 1e-5
    rot = fap_rotation(faps, turns)
    assert np.allclose(rotation_to_gaze_faps(rot[None])[0] * 1e-5, [yaw, pitch], atol=1e-9)


def test_sampling_holds_the_ends_and_follows_an_offset():
    frames = np.arange(5.0)[:, None, None] * np.ones((1, 2, 3))
    seq = MeshSequence(np.zeros((2, 3)), np.array([[0, 1, 1]]), frames, 10.0, "a.npy")
    assert sample(seq, 5, 10.0)[:, 0, 0].tolist() == [0, 1, 2, 3, 4]
    assert sample(seq, 4, 10.0, offset=0.2)[:, 0, 0].tolist() == [0, 0, 0, 1]
    assert sample(seq, 3, 5.0)[:, 0, 0].tolist() == [0, 2, 4]
    assert sample(seq, 8, 10.0)[-1, 0, 0] == 4.0  # past the end: the last frame


def test_a_turn_baked_into_the_vertices_is_taken_out_as_the_heads():
    head = head_mesh(14, 18)
    frames = talking(head, np.linspace(0.0, 0.2, 6))
    rot = rodrigues(np.column_stack([np.zeros(6), np.linspace(0, 0.3, 6), np.zeros(6)]))
    turned = np.einsum("tab,tvb->tva", rot, frames) + np.array([0.0, 0.002, 0.0])
    stable = np.flatnonzero(head.vertices[:, 1] > 0.02)
    back, found = stabilise(head.vertices, turned.astype(np.float32), stable)
    assert found is not None and np.allclose(found, rot, atol=1e-5)
    assert np.allclose(back, frames, atol=1e-5)
    same, none = stabilise(head.vertices, frames.astype(np.float32), stable)
    assert none is None and same is not None


def test_rigid_fit_recovers_a_rotation():
    rng = np.random.default_rng(0)
    p = rng.normal(size=(20, 3))
    r = rodrigues(np.array([[0.2, -0.4, 0.1]]))
    rot, trans = rigid_fit(p, (p @ r[0].T + [1.0, 2.0, 3.0])[None])
    assert np.allclose(rot[0], r[0]) and np.allclose(trans[0], [1, 2, 3])


def test_bundles_read_back(tmp_path):
    head = head_mesh(10, 12)
    seq = MeshSequence(
        head.vertices,
        head.triangles,
        talking(head, np.zeros(3)).astype(np.float32),
        25.0,
        "x.npy",
        units="biwi",
        lips=head.lips,
        eyeballs=head.eyeballs,
        head_weights=np.ones(len(head.vertices)),
        pivot=np.zeros(3),
        kind="flame",
    )
    back = read_bundle(write_bundle(seq, tmp_path / "x.mesh.npz"))
    assert back.digest() == seq.digest() and back.units == "biwi" and back.label == "x.npy"
