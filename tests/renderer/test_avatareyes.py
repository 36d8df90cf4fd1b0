"""Eyes found under every tool's naming, their sides by where they are (renderer.avatareyes)."""

import numpy as np
import pytest

from renderer.avatareyes import eye_geometry, eye_side, find_eyes, words

LEFT_RIGHT = [
    ("eyeLeft", "eyeRight"),
    ("grp_eyeLeft", "grp_eyeRight"),
    ("Eye_L", "Eye_R"),
    ("eye_L", "eye_R"),
    ("eye.L", "eye.R"),
    ("L_Eye", "R_Eye"),
    ("lEye", "rEye"),
    ("LeftEye", "RightEye"),
    ("Left_Eye", "Right_Eye"),
    ("mixamorig:LeftEye", "mixamorig:RightEye"),
    ("CC_Base_L_Eye", "CC_Base_R_Eye"),
    ("J_Adj_L_FaceEye", "J_Adj_R_FaceEye"),
    ("FACIAL_L_Eye", "FACIAL_R_Eye"),
    ("EyeLeft Wolf3D_Eye", "EyeRight Wolf3D_Eye"),
    ("LeftEyeball", "RightEyeball"),
]
NOT_EYES = [
    "Eyebrow_L",
    "eyelash_R",
    "EyeWhite",
    "J_Adj_L_FaceEyeHighlight",
    "LeftEyeLid",
    "eyeBlink_L",
    "eyeLookInLeft",
    "HeadTop_End",
    "Wolf3D_Head",
    "Eye_target",
    "L_Eyeline",
]


@pytest.mark.parametrize(("left", "right"), LEFT_RIGHT)
def test_every_convention_reads_as_an_eye_of_its_side(left, right):
    assert (eye_side(left), eye_side(right)) == ("l", "r")


@pytest.mark.parametrize("name", NOT_EYES)
def test_the_eyes_surroundings_are_no_eyes(name):
    assert eye_side(name) is None


def test_words_split_case_and_punctuation():
    assert words("J_Adj_L_FaceEye") == ["j", "adj", "l", "face", "eye"]
    assert words("eye.L") == ["eye", "l"] and words("HTMLEye") == ["html", "eye"]


def _nodes(names, holds, depth, x):
    return find_eyes(names, np.array(holds), np.array(depth), np.array(x, float))


def test_the_side_comes_from_the_geometry_when_the_names_are_the_cameras():
    # Face Cap: eyeLeft holds the eye at -x, the character's right
    found = _nodes(["head", "eyeLeft", "eyeRight"], [900, 60, 60], [0, 1, 1], [0, -3.0, 3.0])
    assert found.nodes == {"l": 2, "r": 1} and "camera" in found.how
    found = _nodes(["head", "eyeLeft", "eyeRight"], [900, 60, 60], [0, 1, 1], [0, 3.0, -3.0])
    assert found.nodes == {"l": 1, "r": 2} and found.how == "by name"


def test_the_candidate_holding_the_eyeball_wins_the_deeper_on_a_tie():
    names = ["grp_eyeLeft", "eyeLeft", "LeftEye", "grp_eyeRight", "eyeRight", "EyeRight_mesh"]
    holds = [60, 60, 0, 60, 60, 0]
    depth = [1, 2, 5, 1, 2, 0]
    x = [3.0, 3.0, 3.0, -3.0, -3.0, -3.0]
    assert _nodes(names, holds, depth, x).nodes == {"l": 1, "r": 4}


def test_eyes_without_side_words_are_told_apart_by_place():
    found = _nodes(["Eye", "Eye.001", "Body"], [50, 50, 900], [1, 1, 0], [-3.0, 3.0, 0.0])
    assert found.nodes == {"l": 1, "r": 0} and found.how.startswith("by place")
    assert _nodes(["Body", "Head"], [900, 800], [0, 1], [0.0, 0.0]) is None
    assert _nodes(["Eye", "Body"], [50, 900], [1, 0], [0.0, 0.0]) is None  # one eye alone


def _eyeball(centre, radius, front_only=False):
    k = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    ring = np.column_stack([np.cos(k), np.sin(k), np.zeros_like(k)]) * radius
    points = [ring + centre, np.array([centre + [0, 0, radius]])]
    if not front_only:
        points.append(np.array([centre - [0, 0, radius]]))
    return np.vstack(points)


def test_a_bone_away_from_its_eyeball_gives_way_to_the_eyeball():
    centre = np.array([32.0, 0.0, 70.0])
    eye = _eyeball(centre, 12.0)
    assert eye_geometry(eye, centre, 64.0) is None  # the bone is in the eyeball: kept
    # VRoid: the bone medial and 60 mm behind the iris
    pupil, pivot = eye_geometry(eye, np.array([13.0, 0.0, 10.0]), 26.0)
    assert np.allclose(pupil, [32.0, 0.0, 82.0])
    assert pivot[2] < pupil[2] and np.allclose(pivot[:2], [32.0, 0.0])
    assert eye_geometry(eye[:3], np.zeros(3), 26.0) is None  # too few vertices to say
