"""The mosaic hides the mouth at every pose: no pixel outside its blocks follows the mouth.

The pose box a capture reaches (yaw -35..35, pitch -20..20, roll -15..15 degrees), at its
corners and centre, with the jaw closed and opened to 350 (what the synthetic ground truth
reaches) and to 1024 (the jaw's full range), on raw frames before encoding.
"""

import itertools

import numpy as np
import pytest
from scipy import ndimage

from app.stimuli.track import MotionTrack
from renderer.camera import camera_for, project
from renderer.deform import MOUTH_FAPS, Rig
from renderer.headmodel import builtin_face
from renderer.mouthregion import motion_envelope, upper_face
from renderer.pipeline import render_frames

pytestmark = pytest.mark.gl
SIZE = 128
BACKGROUND = (0.55, 0.56, 0.58)
DEG = np.radians(1.0) / 1e-5  # FAP units (1e-5 rad) per degree
CORNERS = [(0, 0, 0), *itertools.product((-35, 35), (-20, 20), (-15, 15))]
#: lip FAPs the jaw's opening comes with (lower lip down, corners stretched, upper lip up)
LIPS = {5: -150, 6: 80, 7: 80, 12: 120, 13: 120, 53: 90, 55: -60, 56: -60}


def _closed_then_open(yaw, pitch, roll, jaw):
    """Two frames at one pose: the mouth at rest, then the jaw at ``jaw`` with the lips."""
    pose = {49: yaw * DEG, 48: pitch * DEG, 50: roll * DEG}
    mouth = {3: jaw, **LIPS}
    channels = {k: np.array([v, v]) for k, v in pose.items()}
    channels.update({k: np.array([0.0, v]) for k, v in mouth.items()})
    return MotionTrack.from_channels(30.0, channels)


def _frames(track, block):
    kwargs = dict(size=SIZE, background=BACKGROUND, mosaic_block=block, mosaic_margin=0.15)
    frames = render_frames([track], builtin_face(), **kwargs)
    return [(f.image.copy(), _blocks(f, block)) for f in frames]


def _blocks(frame, block):
    """The pixels of the frame's (one face's) mosaic blocks, (H, W) bool."""
    inside = np.zeros(frame.image.shape[:2], bool)
    for (x0, y0, x1, y1), cells in zip(frame.boxes, frame.cells, strict=True):
        inside[y0:y1, x0:x1] = np.repeat(np.repeat(cells, block, 0), block, 1)
    return inside


def _background_mask(image):
    bg = np.round(np.array(BACKGROUND) * 255).astype(np.uint8)
    return (image == bg).all(axis=2)


@pytest.mark.parametrize("jaw", [350, 1024])
def test_every_pixel_the_mouth_changes_lies_in_the_mosaic(jaw):
    # drawn without the mosaic, the open mouth changes pixels (lips, chin, the jaw's outline,
    # the neck it uncovers); all of them lie inside the box the mosaic puts there
    for pose in CORNERS:
        track = _closed_then_open(*pose, jaw)
        (closed, _), (opened, _) = _frames(track, 0)
        (_, inside), (_, inside_open) = _frames(track, 8)
        assert np.array_equal(inside, inside_open)  # the blocks follow the head, not the mouth
        # more than one level: a level's shading change of the cheek beside an eye, which the
        # blocks leave alone (the next test), is no motion shown
        changed = (np.abs(closed.astype(int) - opened.astype(int)) > 1).any(axis=2)
        assert changed.sum() > 100, pose  # the jaw does open
        assert not (changed & ~inside).any(), (pose, int((changed & ~inside).sum()))
        assert inside[: int(SIZE * 0.4)].sum() == 0 or pose[2] != 0  # below the eyes


@pytest.mark.parametrize("jaw", [350, 1024])
def test_with_the_mosaic_the_open_mouth_changes_no_pixel_and_leaves_no_hole(jaw):
    for pose in CORNERS:
        (closed, _), (opened, _) = _frames(_closed_then_open(*pose, jaw), 8)
        assert np.array_equal(closed, opened), pose
        background = _background_mask(opened)
        holes = ndimage.binary_fill_holes(~background) & background
        assert not holes.any(), (pose, int(holes.sum()))


def test_no_block_covers_the_eyes_or_brows_at_any_pose():
    """Pitched down 20 degrees, the blocks reached the lower half of both irises; turned and
    pitched, the inner ends of the brows."""
    rig = Rig(builtin_face())
    vp, _ = camera_for(rig)
    watched = upper_face(rig)
    assert set(rig.eye_vertices["l"]) <= set(watched) and len(watched) > 400
    for pose in CORNERS + [(0, -20, 0), (0, 20, 0)]:
        track = _closed_then_open(*pose, 350)
        for (_, inside), faps in zip(_frames(track, 8), track.dense(), strict=True):
            at_rest = np.where(np.isin(np.arange(1, 69), MOUTH_FAPS), 0.0, faps)
            pos, _ = rig.posed(rig.deform(at_rest))
            xy = np.round(project(vp, pos[watched].astype(np.float64), SIZE)).astype(int)
            covered = inside[xy[:, 1], xy[:, 0]]
            assert not covered.any(), (pose, int(covered.sum()))


def test_the_envelope_is_the_lower_face_and_grows_with_the_jaw():
    rig = Rig(builtin_face())
    fp = rig.face.feature_points
    tracks = {}
    for jaw in (0, 350, 1024):
        values = np.zeros((3, 68))
        values[1, 2] = jaw
        tracks[jaw] = motion_envelope(rig, [values]).points
    assert len(tracks[0]) == 0  # a still mouth moves nothing: the box is the lips' own
    low = {jaw: float(tracks[jaw][:, 1].min()) for jaw in (350, 1024)}
    assert low[1024] < low[350] - 5 and low[350] < fp["2.1"][1] - 5  # the chin's arc
    for jaw in (350, 1024):  # never above the nose's base
        assert tracks[jaw][:, 1].max() < fp["9.15"][1] + 30


def test_both_faces_of_a_pair_get_the_region_of_both_clips():
    rig = Rig(builtin_face())
    still = np.zeros((5, 68))
    talking = still.copy()
    talking[2, 2] = 500
    one = motion_envelope(rig, [still, talking]).points
    both = motion_envelope(rig, [talking, still]).points
    assert np.array_equal(np.sort(one, axis=0), np.sort(both, axis=0))
    vp, _ = camera_for(rig)
    chin = project(vp, rig.face.feature_points["2.1"][None], SIZE)
    assert project(vp, one, SIZE)[:, 1].max() > chin[0, 1] + 3  # the still face's box too
