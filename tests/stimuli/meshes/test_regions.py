"""Lips, upper face and eyeballs: from the projects' region files, else from the mesh."""

import doctest
import json
import pickle

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.meshes import regions
from app.stimuli.meshes.regions import (
    find_eyeballs,
    find_lips,
    mouth_points_of,
    read_regions,
    speech_energy,
    upper_face_band,
)
from tests.stimuli.meshes.synthetic import head_mesh, opening_from_energy, talking

DEMO = "app/data/demo/speech.wav"


def test_doctests():
    assert doctest.testmod(regions).failed == 0


def test_codetalker_folder_flame_masks_json_and_lists(tmp_path):
    folder = tmp_path / "regions"
    folder.mkdir()
    (folder / "lve.txt").write_text("3, 4, 5")
    (folder / "fdd.txt").write_text("7, 8")
    r = read_regions(folder, 10)
    assert r.lips.tolist() == [3, 4, 5] and r.upper.tolist() == [7, 8]
    masks = {
        "lips": np.array([1, 2]),
        "forehead": np.array([6]),
        "eye_region": np.array([7, 6]),
        "left_eyeball": np.array([8]),
        "right_eyeball": np.array([9]),
        "scalp": np.array([0]),
    }
    (tmp_path / "FLAME_masks.pkl").write_bytes(pickle.dumps(masks, protocol=2))
    r = read_regions(tmp_path / "FLAME_masks.pkl", 10)
    assert r.lips.tolist() == [1, 2] and r.upper.tolist() == [6, 7]
    assert [e.tolist() for e in r.eyeballs] == [[8], [9]]
    (tmp_path / "r.json").write_text(json.dumps({"lve": [1], "upper": [2, 3]}))
    assert read_regions(tmp_path / "r.json", 10).upper.tolist() == [2, 3]
    np.save(tmp_path / "mouth_idx.npy", np.array([4, 2]))
    assert read_regions(tmp_path / "mouth_idx.npy", 10).lips.tolist() == [2, 4]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("1, 2, x", "lve.txt: expected vertex indices separated by commas"),
        ("1, 20", "lve.txt: lips: vertex 20 is not among the mesh's 10"),
        ("", "lve.txt: lips: no vertex"),
    ],
)
def test_bad_region_files_are_one_line(tmp_path, text, message):
    (tmp_path / "lve.txt").write_text(text)
    with pytest.raises(InputError) as err:
        read_regions(tmp_path / "lve.txt", 10)
    assert str(err.value) == message


def test_eyeballs_are_found_on_flame_like_meshes_and_not_on_scans():
    head = head_mesh(24, 30)
    left, right = find_eyeballs(head.vertices, head.triangles)
    assert set(left) == set(head.eyeballs[0]) and set(right) == set(head.eyeballs[1])
    assert head.vertices[left, 0].mean() > 0  # the face's own left is +x
    eyeless = head_mesh(24, 30, eyes=False)
    assert find_eyeballs(eyeless.vertices, eyeless.triangles) is None


def test_the_lips_are_found_from_the_motion_that_follows_the_speech():
    head = head_mesh(30, 40)
    energy = speech_energy(DEMO, 30.0, 120)
    frames = talking(head, opening_from_energy(energy), brows=0.004)
    mouth = find_lips(head.vertices, frames, energy, exclude=np.concatenate(head.eyeballs))
    assert mouth.upper in head.lips and mouth.lower in head.lips
    assert set(head.lips) <= set(mouth.lips)
    width = np.ptp(head.vertices[:, 0])
    assert np.ptp(head.vertices[mouth.lips, 0]) < 0.45 * width  # a mouth, not the jaw
    assert mouth.lower in head.lips[len(head.lips) // 2 :]  # the moving (lower) lip
    # the brows move too, every other frame, but not with the speech: they are not the lips
    assert head.vertices[mouth.lips, 1].max() < 0.0
    back = mouth_points_of(head.vertices, mouth.lips)
    assert abs(head.vertices[back.upper, 1] - head.vertices[mouth.upper, 1]) < 0.01
    upper = upper_face_band(head.vertices, mouth)
    assert head.vertices[upper, 1].min() > head.vertices[mouth.upper, 1] + 0.04


def test_a_still_mesh_has_no_lips_to_find():
    head = head_mesh(12, 16)
    frames = np.repeat(head.vertices[None], 3, axis=0)
    with pytest.raises(InputError, match="still.npy: no vertex moves, so the lips cannot be found"):
        find_lips(head.vertices, frames, None, name="still.npy")


def test_speech_energy_has_a_value_per_frame():
    e = speech_energy(DEMO, 25.0, 100)
    assert e.shape == (100,) and e.max() - e.min() > 20  # speech and pauses
