import numpy as np
import pytest

import renderer.gl as gl
from renderer import GLUnavailable
from renderer.deform import Rig
from renderer.headmodel import builtin_face


def test_no_context_gives_one_line_saying_what_to_install(monkeypatch):
    import moderngl

    def fail(**kwargs):
        raise Exception("eglGetDisplay failed\nmore detail")

    monkeypatch.setattr(moderngl, "create_standalone_context", fail)
    monkeypatch.setattr(gl, "_CONTEXTS", {})
    with pytest.raises(GLUnavailable) as info:
        gl.context()
    msg = str(info.value)
    assert "\n" not in msg and "apt-get install libegl1" in msg and "eglGetDisplay" in msg


def test_projection_puts_the_face_in_the_middle():
    rig = Rig(builtin_face())
    vp, eye = gl.camera_for(rig)
    fp = rig.face.feature_points
    px = gl.project(vp, np.array([fp["9.15"], fp["3.5"], fp["3.6"]]), 368)
    assert abs(px[0, 0] - 184) < 2 and 100 < px[0, 1] < 260
    assert px[1, 0] > px[2, 0]  # the face's left eye appears on the viewer's right
    assert eye[2] > fp["9.3"][2]


@pytest.mark.gl
def test_canvas_draws_faces_on_a_neutral_background():
    rig = Rig(builtin_face())
    canvas = gl.FaceCanvas(rig, 128, 2, samples=4, background=(0.5, 0.5, 0.5))
    try:
        frame = rig.deform(np.zeros(68))
        img = canvas.draw([frame, frame]).copy()
    finally:
        canvas.release()
    assert img.shape == (128, 256, 3)
    assert np.abs(img[2, 2].astype(int) - 128).max() <= 2  # background corner
    assert np.array_equal(img[:, :128], img[:, 128:])
    centre = img[40:90, 40:90].astype(int)
    assert (np.abs(centre - 128).sum(axis=2) > 30).mean() > 0.8  # the face covers the middle
