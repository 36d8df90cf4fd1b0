"""Mesh and FLAME conditions as tracks: each layout, the full vertex counts, bad input in one
line, and the bundle a generated condition leaves beside its ``.fap``."""

import doctest

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.fap import HEAD_YAW
from app.stimuli.io import load_track, save_track
from app.stimuli.meshes import fairness, source
from app.stimuli.meshes.fairness import match_mesh_eyes
from app.stimuli.meshes.source import MeshOptions, mesh_of, mesh_track
from app.stimuli.track import MotionTrack
from tests.stimuli.meshes.synthetic import (
    flame_like_model,
    head_mesh,
    talking,
    write_flame_pkl,
    write_layout,
)


def test_doctests():
    assert doctest.testmod(source).failed == 0
    assert doctest.testmod(fairness).failed == 0


@pytest.fixture(scope="module")
def head():
    return head_mesh(16, 20)


def test_faceformer_and_selftalk_layouts_read_alike(tmp_path, head):
    frames = talking(head, np.linspace(0, 0.2, 10))
    flat = write_layout(tmp_path / "ff", "face", head, frames, flat=True)
    stacked = write_layout(tmp_path / "st", "face", head, frames, flat=False, template=".ply")
    a = mesh_of(mesh_track(flat, MeshOptions(fps=30)))
    b = mesh_of(mesh_track(stacked, MeshOptions(fps=30)))
    assert a is not None and b is not None
    assert np.allclose(a.frames, b.frames, atol=1e-6) and a.units == "m"
    assert a.eyeballs is not None  # found as two mirrored parts of the mesh


def test_a_biwi_layout_in_biwis_units_at_its_full_vertex_count(tmp_path):
    head = head_mesh(40, 48, eyes=False, n_vertices=23370)
    frames = talking(head, np.linspace(0, 0.2, 5))
    path = write_layout(tmp_path, "M1_e37", head, frames, flat=True, scale=0.2)
    assert np.load(path).shape == (5, 70110)  # FaceFormer's --vertice_dim for BIWI
    track = mesh_track(path, MeshOptions(fps=25), fps=25)
    seq = mesh_of(track)
    assert seq is not None and seq.units == "biwi" and seq.eyeballs is None
    assert np.allclose(seq.frames, frames, atol=1e-6)  # back in metres
    assert track.n_frames == 5 and track.metadata["mesh_eyes"] is False


def test_the_vocaset_flame_topologys_full_count(tmp_path):
    head = head_mesh(n_vertices=5023)
    name = "FaceTalk_170809_00138_TA_sentence01"
    path = write_layout(tmp_path, name, head, talking(head, np.zeros(3)), flat=True)
    assert np.load(path).shape == (3, 15069)  # FaceFormer's --vertice_dim for VOCASET
    assert mesh_of(mesh_track(path, MeshOptions(fps=30))).n_vertices == 5023


def test_an_explicit_template_and_the_frame_rate_to_a_track(tmp_path, head):
    frames = talking(head, np.linspace(0, 0.2, 50))
    path = write_layout(tmp_path, "face", head, frames, flat=True)
    other = tmp_path / "elsewhere.obj"
    (tmp_path / "face.obj").rename(other)
    with pytest.raises(InputError) as err:
        mesh_track(path, MeshOptions(fps=25))
    assert str(err.value) == (
        "face.npy: no template mesh: put face.obj or face.ply beside it, or name one "
        "(--template, or template in the study file)"
    )
    track = mesh_track(path, MeshOptions(fps=25, template=str(other)), fps=30)
    assert track.n_frames == 60 and track.duration == pytest.approx(2.0)  # 50 at 25 fps


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"fps": None}, "face.npy: give the sequence's frame rate (--mesh-fps"),
        ({"units": "mm"}, "face.obj: units implausible: in mm the template is"),
    ],
)
def test_bad_options_are_one_line(tmp_path, head, change, message):
    path = write_layout(tmp_path, "face", head, talking(head, np.zeros(3)), flat=True)
    options = {"fps": 30.0, **change}
    with pytest.raises(InputError) as err:
        mesh_track(path, MeshOptions(**options))
    assert str(err.value).startswith(message)


def test_a_template_of_another_topology_is_one_line(tmp_path, head):
    path = write_layout(tmp_path, "face", head, talking(head, np.zeros(3)), flat=True)
    small = head_mesh(8, 10)
    write_layout(tmp_path, "face", small, talking(small, np.zeros(1)), flat=True)
    np.save(path, talking(head, np.zeros(3)).reshape(3, -1))  # the old sequence, new template
    with pytest.raises(InputError) as err:
        mesh_track(path, MeshOptions(fps=30))
    assert str(err.value) == (
        f"face.npy: {len(head.vertices)} vertices per frame, but the template has "
        f"{len(small.vertices)}"
    )


def test_a_head_pose_file_beside_becomes_the_heads_channels(tmp_path, head):
    path = write_layout(tmp_path, "face", head, talking(head, np.zeros(4)), flat=True)
    pose = np.zeros((4, 3))
    pose[:, 1] = [0.0, 0.1, 0.2, 0.3]  # yaw, radians
    np.save(tmp_path / "face.pose.npy", pose)
    track = mesh_track(path, MeshOptions(fps=30))
    assert np.allclose(track[HEAD_YAW], pose[:, 1] / 1e-5)


def test_flame_parameters_need_the_users_model_and_then_render_its_vertices(
    tmp_path, head, monkeypatch
):
    monkeypatch.delenv("FACEPAIR_FLAME_MODEL", raising=False)
    pose = np.zeros((6, 6))
    pose[:, 3] = np.linspace(0, 0.2, 6)  # the jaw
    pose[:, 1] = 0.1  # a turn of the head (global rotation about y)
    np.savez(tmp_path / "dpt.npz", exp=np.zeros((6, 50)), pose=pose, shape=np.zeros(100))
    with pytest.raises(InputError) as err:
        mesh_track(tmp_path / "dpt.npz", MeshOptions(fps=25))
    assert str(err.value).startswith("dpt.npz: a FLAME parameter sequence needs your own FLAME")
    model = write_flame_pkl(tmp_path / "generic_model.pkl", flame_like_model(head))
    monkeypatch.setenv("FACEPAIR_FLAME_MODEL", str(model))
    track = mesh_track(tmp_path / "dpt.npz", MeshOptions(fps=25), fps=25)
    seq = mesh_of(track)
    assert seq is not None and seq.kind == "flame" and seq.eyeballs is not None
    assert np.allclose(track[HEAD_YAW], 0.1 / 1e-5)  # the head's turn is the track's
    lower = head.lips[len(head.lips) // 2 :]
    assert seq.frames[-1, lower, 1].mean() < seq.frames[0, lower, 1].mean() - 0.005  # jaw open


def test_a_generated_mesh_track_carries_its_bundle_beside_its_fap(tmp_path, head):
    path = write_layout(tmp_path, "face", head, talking(head, np.linspace(0, 0.2, 9)), flat=True)
    read = mesh_track(path, MeshOptions(fps=30))
    track = read.replace(metadata={**read.metadata, "offset_s": 1 / 30})  # aligned a frame late
    (tmp_path / "out").mkdir()
    save_track(track, tmp_path / "out" / "ff.fap")
    back = load_track(tmp_path / "out" / "ff.fap")
    seq = mesh_of(back)
    assert seq is not None and seq.n_frames == track.n_frames and seq.fps == 30
    original = mesh_of(track)
    assert np.allclose(seq.frames[1:], original.frames[:-1])  # started a frame late
    save_track(MotionTrack.zeros(30, 3), tmp_path / "out" / "ff.fap")  # now a FAP track
    assert not (tmp_path / "out" / "ff.mesh.npz").exists()
    assert mesh_of(load_track(tmp_path / "out" / "ff.fap")) is None


def test_beside_a_mesh_without_eyeballs_no_face_blinks_or_looks_about():
    built_in = MotionTrack.from_channels(30, {19: np.ones(3), 25: np.ones(3), 49: np.ones(3)})
    eyeless = MotionTrack.zeros(30, 3).replace(metadata={"mesh": {}, "mesh_eyes": False})
    with_eyes = MotionTrack.from_channels(30, {25: np.ones(3)}).replace(
        metadata={"mesh": {}, "mesh_eyes": True}
    )
    out, note = match_mesh_eyes({"b": built_in, "m": eyeless}, "match")
    assert not out["b"].get(19).any() and not out["b"].get(25).any() and out["b"][49].all()
    assert "m has no eyeballs" in note
    out, note = match_mesh_eyes({"b": built_in, "m": with_eyes}, "match")
    assert not out["b"].get(19).any() and out["b"][25].all() and out["m"][25].all()
    out, note = match_mesh_eyes({"b": built_in, "m": eyeless}, "own")
    assert out["b"][19].all() and "a confound" in note
    assert match_mesh_eyes({"b": built_in}, "match") == ({"b": built_in}, None)
    with pytest.raises(InputError, match="mesh_eyes: expected one of match, own"):
        match_mesh_eyes({"b": built_in}, "blink")
