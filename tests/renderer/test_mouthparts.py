"""The mouth of the built-in head, in pixels, over the pose box a capture reaches.

No background through the open mouth (the cavity is closed onto the lips), teeth and tongue
only inside the lips' opening and hidden when the mouth is closed, and the incisors, not
the corners, reaching furthest down (no fangs).
"""

import dataclasses
import itertools

import numpy as np
import pytest
from scipy import ndimage

from renderer.deform import Rig
from renderer.gl import FaceCanvas
from renderer.headmodel import MOUTH_Y, builtin_face
from renderer.mouthparts import mouth_parts

pytestmark = pytest.mark.gl
SIZE = 160
DEG = np.radians(1.0) / 1e-5
BACKGROUND = (0.55, 0.56, 0.58)
POSES = [(0, 0, 0), *itertools.product((-35, 35), (-20, 20), (-15, 15))]
GREEN = np.array([0.0, 1.0, 0.0, 0.0])


def _marked_face():
    """The built-in head with its teeth and tongue painted pure green."""
    face = builtin_face()
    inside = mouth_parts(MOUTH_Y).vertices.astype(np.float32)
    rows = face.vertices.view([("", np.float32)] * 3).ravel()
    marked = np.isin(rows, inside.view([("", np.float32)] * 3).ravel())
    assert marked.sum() == len(inside)
    colors = face.colors.copy()
    colors[marked] = GREEN
    return dataclasses.replace(face, colors=colors, name="marked"), marked


def _draw(rig, pose, jaw, **lips):
    yaw, pitch, roll = pose
    faps = np.zeros(68)
    faps[[48, 47, 49]] = yaw * DEG, pitch * DEG, roll * DEG
    faps[2] = jaw
    for k, v in lips.items():
        faps[int(k[1:]) - 1] = v
    canvas = FaceCanvas(rig, SIZE, background=BACKGROUND)
    try:
        return canvas.draw([rig.deform(faps)]).copy()
    finally:
        canvas.release()


def _green(image):
    g = image.astype(int)
    return (g[..., 1] > g[..., 0] + 40) & (g[..., 1] > g[..., 2] + 40)


@pytest.fixture(scope="module")
def marked():
    face, _ = _marked_face()
    return Rig(face)


def test_no_background_shows_inside_the_head_at_any_pose_or_opening():
    rig = Rig(builtin_face())
    bg = np.round(np.array(BACKGROUND) * 255).astype(np.uint8)
    for pose in POSES:
        for jaw in (0, 350, 1024):
            image = _draw(rig, pose, jaw, f5=-150, f12=100, f13=100)
            background = (image == bg).all(axis=2)
            holes = ndimage.binary_fill_holes(~background) & background
            assert not holes.any(), (pose, jaw, int(holes.sum()))


def test_teeth_and_tongue_hide_behind_closed_lips(marked):
    for pose in POSES:
        assert not _green(_draw(marked, pose, 0)).any(), pose


def test_teeth_and_tongue_show_only_inside_the_open_lips(marked):
    rig = Rig(builtin_face())
    shown = 0
    for pose in POSES:
        for jaw in (350, 1024):
            green = _green(_draw(marked, pose, jaw))
            shown += int(green.sum() > 5)
            # the lips' opening: what the open mouth adds to the closed one, filled
            closed, opened = _draw(rig, pose, 0), _draw(rig, pose, jaw)
            mouth = ndimage.binary_fill_holes(
                ndimage.binary_closing((closed != opened).any(axis=2), iterations=2)
            )
            assert not (green & ~ndimage.binary_dilation(mouth, iterations=1)).any(), (pose, jaw)
    assert shown > len(POSES)  # they do show, at most poses


def test_the_incisors_reach_furthest_down_not_the_corners(marked):
    # front view, jaw wide open: the upper teeth's lowest pixel in each third of their
    # width; fang-like corners hung below the middle
    image = _draw(marked, (0, 0, 0), 1024)
    green = _green(image)
    ys, xs = np.nonzero(green)
    upper = ys < np.median(ys)  # the upper arch lies above the lower one and the tongue
    ys, xs = ys[upper], xs[upper]
    thirds = np.array_split(np.arange(xs.min(), xs.max() + 1), 3)
    lowest = [ys[np.isin(xs, t)].max() for t in thirds]
    assert lowest[1] >= max(lowest[0], lowest[2])


def test_closed_lips_hide_the_whole_inside_of_the_mouth():
    # the mosaic's face (its mouth at rest) is drawn without the cavity, teeth and tongue:
    # at every pose, with the brows and lids moving, not one pixel differs
    rig = Rig(builtin_face())
    canvas = FaceCanvas(rig, SIZE, background=BACKGROUND)
    try:
        first, end = canvas.closed_mouth
        assert end - first < builtin_face().n_triangles - 900  # the inside is left out
        for pose in POSES:
            faps = np.zeros(68)
            faps[[48, 47, 49]] = np.array(pose) * DEG
            faps[[18, 30, 31, 34]] = 300.0, 120.0, 120.0, -60.0
            frame = rig.deform(faps)
            whole = canvas.draw([frame]).copy()
            assert np.array_equal(canvas.draw([frame], lips_closed=True), whole), pose
    finally:
        canvas.release()
