"""Mesh sequences drawn as every face is: the mosaic hides their mouth at every pose.

The pose box of the built-in head's test (tests/renderer/test_mouthregion.py: yaw -35..35,
pitch -20..20, roll -15..15 degrees, corners and centre), for a FLAME-like head with eyeballs and
skinning weights to the neck, and a BIWI-like face scan without eyes, the jaw opened by 0.25 and
0.45 radians, on raw frames before encoding.
"""

import dataclasses
import itertools

import numpy as np
import pytest
from scipy import ndimage

from app.stimuli.meshes.sequence import MeshSequence
from app.stimuli.track import MotionTrack
from renderer.camera import camera_for, project
from renderer.headmodel import builtin_face
from renderer.meshface import MeshFace, MeshRig, mesh_face
from renderer.pipeline import render_frames, rig_for
from tests.stimuli.meshes.synthetic import head_mesh, talking

pytestmark = pytest.mark.gl
SIZE = 128
BACKGROUND = (0.55, 0.56, 0.58)
DEG = np.radians(1.0) / 1e-5
CORNERS = [(0, 0, 0), *itertools.product((-35, 35), (-20, 20), (-15, 15))]


def _face(kind: str, opening: float, brows: float = 0.0) -> MeshFace:
    head = head_mesh(30, 36, eyes=kind == "flame")
    frames = talking(head, np.array([0.0, opening]), brows=brows).astype(np.float32)
    weights = None
    if kind == "flame":  # FLAME's neck: the bottom of the head follows the turn less
        weights = np.clip((head.vertices[:, 1] + 0.11) / 0.04, 0.2, 1.0)
    seq = MeshSequence(
        head.vertices,
        head.triangles,
        frames,
        30.0,
        f"{kind}.npy",
        lips=head.lips,
        eyeballs=head.eyeballs,
        head_weights=weights,
    )
    return mesh_face(seq)


def _posed(yaw, pitch, roll, n=2):
    pose = {49: yaw * DEG, 48: pitch * DEG, 50: roll * DEG}
    return MotionTrack.from_channels(30.0, {k: np.full(n, v) for k, v in pose.items()})


def _blocks(frame, block):
    inside = np.zeros(frame.image.shape[:2], bool)
    for (x0, y0, x1, y1), cells in zip(frame.boxes, frame.cells, strict=True):
        inside[y0:y1, x0:x1] = np.repeat(np.repeat(cells, block, 0), block, 1)
    return inside


def _frames(tracks, faces, block):
    kwargs = dict(size=SIZE, background=BACKGROUND, mosaic_block=block, mosaic_margin=0.15)
    return [(f.image.copy(), _blocks(f, block)) for f in render_frames(tracks, faces, **kwargs)]


@pytest.mark.parametrize("kind", ["flame", "biwi"])
@pytest.mark.parametrize("opening", [0.25, 0.45])
def test_every_pixel_the_mouth_changes_lies_in_the_mosaic(kind, opening):
    face = _face(kind, opening)
    for pose in CORNERS:
        track = _posed(*pose)
        (closed, _), (opened, _) = _frames([track], [face], 0)
        (_, inside), (_, inside_open) = _frames([track], [face], 8)
        assert np.array_equal(inside, inside_open)  # the blocks follow the head, not the mouth
        changed = (np.abs(closed.astype(int) - opened.astype(int)) > 1).any(axis=2)
        assert changed.sum() > 60, pose  # the jaw does open
        assert not (changed & ~inside).any(), (pose, int((changed & ~inside).sum()))


@pytest.mark.parametrize("kind", ["flame", "biwi"])
def test_with_the_mosaic_the_open_mouth_changes_no_pixel_and_leaves_no_hole(kind):
    face = _face(kind, 0.45)
    for pose in CORNERS:
        (closed, _), (opened, _) = _frames([_posed(*pose)], [face], 8)
        assert np.array_equal(closed, opened), pose
        background = (opened == np.round(np.array(BACKGROUND) * 255).astype(np.uint8)).all(axis=2)
        holes = ndimage.binary_fill_holes(~background) & background
        assert not holes.any(), (pose, int(holes.sum()))


def test_no_block_covers_the_eyes_and_the_brows_still_move_in_view():
    face = _face("flame", 0.45, brows=0.003)
    rig = rig_for(face)
    assert isinstance(rig, MeshRig)
    vp, _ = camera_for(rig)
    eyes = np.concatenate([face.groups["eyeball_l"], face.groups["eyeball_r"]])
    assert set(eyes) <= set(face.upper_face)
    for pose in CORNERS + [(0, -20, 0), (0, 20, 0)]:
        track = _posed(*pose)
        frames = _frames([track], [face], 8)
        for (_, inside), i in zip(frames, range(2), strict=True):
            posed = rig.frame(face.sequence.frames[i], track.dense()[i])
            pos, _ = rig.posed(posed)
            xy = np.round(project(vp, pos[eyes].astype(np.float64), SIZE)).astype(int)
            visible = (xy >= 0).all(axis=1) & (xy < SIZE).all(axis=1)
            assert not inside[xy[visible, 1], xy[visible, 0]].any(), pose
        # the forehead's own motion (the file's brows) is drawn, outside the blocks
        (a, inside), (b, _) = frames
        changed = (np.abs(a.astype(int) - b.astype(int)) > 1).any(axis=2) & ~inside
        assert changed[: SIZE // 2].sum() > 5, pose


def test_a_mesh_beside_the_built_in_head_each_framed_on_its_own():
    face = _face("biwi", 0.3)
    built_in = builtin_face("plain")
    still = MotionTrack.zeros(30.0, 2, (3,))
    kwargs = dict(size=SIZE, background=BACKGROUND, mosaic_block=0)
    pair = [f.image.copy() for f in render_frames([still, still], [face, built_in], **kwargs)]
    alone = [f.image.copy() for f in render_frames([still], [built_in], **kwargs)]
    mesh_alone = [f.image.copy() for f in render_frames([still], [face], **kwargs)]
    for i in range(2):
        assert np.array_equal(pair[i][:, SIZE:], alone[i])  # the built-in side is as drawn alone
        assert np.array_equal(pair[i][:, :SIZE], mesh_alone[i])
    # both faces fill their side: the mesh is framed by its own feature points
    for side in (pair[0][:, :SIZE], pair[0][:, SIZE:]):
        face_px = ~(side == np.round(np.array(BACKGROUND) * 255).astype(np.uint8)).all(axis=2)
        assert 0.15 < face_px.mean() < 0.8
    with_mosaic = render_frames([still, still], [face, built_in], size=SIZE, mosaic_block=8)
    frame = next(with_mosaic)
    assert len(frame.boxes) == 2 and frame.boxes[1][0] >= SIZE  # one mosaic on each side
    with_mosaic.close()


def test_doctests():
    import doctest

    from renderer import faceregions, meshface, meshmosaic

    for module in (meshface, meshmosaic, faceregions):
        assert doctest.testmod(module).failed == 0


@pytest.mark.parametrize("kind", ["flame", "biwi"])
@pytest.mark.parametrize("opening", [0.25, 0.45])
def test_an_open_mouth_shows_the_dark_cavity_not_the_background(kind, opening):
    face = _face(kind, opening)
    n = face.sequence.n_vertices
    assert face.n_vertices > n  # the cavity's points follow the sequence's
    green = dataclasses.replace(face, colors=face.colors.copy())
    green.colors[n:, :3] = (0.0, 1.0, 0.0)
    bare = dataclasses.replace(face, triangles=face.triangles[: len(face.sequence.triangles)])
    for pose in CORNERS:
        track = _posed(*pose)
        holes = {}
        for name, drawn in (("cavity", face), ("bare", bare)):
            _, (opened, _) = _frames([track], [drawn], 0)
            background = (opened == np.round(np.array(BACKGROUND) * 255)).all(axis=2)
            holes[name] = int((ndimage.binary_fill_holes(~background) & background).sum())
        # the background through the head: none from the front; at the pose box's corners
        # a few pixels where the synthetic jaw's open shell lets the eye past the backdrop
        # (the mesh alone shows the background through 50 to 450 pixels of its open mouth)
        assert holes["cavity"] <= (0 if pose == (0, 0, 0) else 20), (pose, holes)
        if pose == (0, 0, 0):
            assert holes["bare"] > 100, holes
        (closed, _), (opened, _) = _frames([track], [face], 0)
        (closed_green, _), (opened_green, _) = _frames([track], [green], 0)
        assert np.array_equal(closed, closed_green), pose  # closed lips hide it
        shows = (np.abs(opened.astype(int) - opened_green.astype(int)) > 1).any(axis=2)
        if pose == (0, 0, 0):  # it is what the open mouth shows
            assert shows.sum() > 10
