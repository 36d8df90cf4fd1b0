"""The fixed camera: framed on the face's feature points, the face in the middle of the view."""

import numpy as np

from renderer.camera import camera_for, project
from renderer.deform import Rig
from renderer.headmodel import builtin_face


def test_projection_puts_the_face_in_the_middle():
    rig = Rig(builtin_face())
    vp, eye = camera_for(rig)
    fp = rig.face.feature_points
    px = project(vp, np.array([fp["9.15"], fp["3.5"], fp["3.6"]]), 368)
    assert abs(px[0, 0] - 184) < 2 and 100 < px[0, 1] < 260
    assert px[1, 0] > px[2, 0]  # the face's left eye appears on the viewer's right
    assert eye[2] > fp["9.3"][2]
