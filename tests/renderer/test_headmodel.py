import numpy as np

from renderer.face import REQUIRED_FEATURE_POINTS
from renderer.headmodel import builtin_face


def test_builtin_face_is_modest_and_complete():
    face = builtin_face()
    assert 3_000 < face.n_triangles < 18_000
    assert all(k in face.feature_points for k in REQUIRED_FEATURE_POINTS)
    assert face.triangles.min() >= 0 and face.triangles.max() < face.n_vertices


def test_feature_points_sit_where_a_face_has_them():
    fp = builtin_face().feature_points
    assert fp["3.5"][0] > 0 > fp["3.6"][0]  # left eye on +x (the face's left)
    assert fp["4.1"][1] > fp["3.1"][1] > fp["3.5"][1] > fp["3.3"][1] > fp["9.15"][1]
    assert fp["9.15"][1] > fp["8.1"][1] > fp["2.2"][1] >= fp["2.3"][1] > fp["8.2"][1]
    assert fp["8.2"][1] > fp["2.10"][1] > fp["2.1"][1]
    assert fp["2.4"][0] > 0 > fp["2.5"][0]
    assert np.isclose(fp["2.2"], fp["2.3"]).all()  # closed mouth, unconnected lips


def test_fapu_are_human_proportions():
    fapu = builtin_face().fapu
    assert 55 < fapu["ES0"] < 70  # millimetres
    assert 0.7 < fapu["MW0"] / fapu["ES0"] < 1.0
    assert 0.2 < fapu["MNS0"] / fapu["ENS0"] < 0.6
    assert 7 < fapu["IRISD0"] < 12


def test_lips_are_not_connected_between_the_corners():
    face = builtin_face()
    i2, i3 = face.fp_vertices["2.2"], face.fp_vertices["2.3"]
    assert i2 != i3
    shared = np.isin(face.triangles, [i2]).any(axis=1) & np.isin(face.triangles, [i3]).any(1)
    assert not shared.any()
