"""Pixels of rendered frames: each FAP group moves the face visibly, the MPEG-4 way."""

import os

import numpy as np
import pytest

from app.stimuli.track import MotionTrack
from renderer.headmodel import builtin_face
from renderer.pipeline import align_tracks, render_frames

pytestmark = pytest.mark.gl
SIZE = 256


def _frame(tracks, mosaic_block=0, index=0, size=SIZE, antialias="edges"):
    gen = render_frames(
        tracks,
        builtin_face(),
        size=size,
        samples=4,
        antialias=antialias,
        background=(0.55, 0.56, 0.58),
        mosaic_block=mosaic_block,
        mosaic_margin=0.15,
        frames=range(index, index + 1),
    )
    out = next(gen)
    gen.close()
    return out.image.copy(), out.boxes


def _track(**faps):
    cols = {int(k[1:]): np.array([float(v)]) for k, v in faps.items()}
    return MotionTrack.from_channels(30.0, cols) if cols else MotionTrack.zeros(30.0, 1)


def _centroid(mask):
    ys, xs = np.nonzero(mask)
    return np.array([xs.mean(), ys.mean()])


def _dark(img, thresh=60):
    return img.astype(int).sum(axis=2) < 3 * thresh


def test_head_yaw_turns_the_head_to_its_own_left_while_the_other_face_stays(tmp_path):
    neutral, _ = _frame([_track(), _track()])
    turned, _ = _frame([_track(), _track(f49=25000)])
    left_n, left_t = neutral[:, :SIZE], turned[:, :SIZE]
    assert np.array_equal(left_n, left_t)  # the other face does not move
    diff = np.abs(turned[:, SIZE:].astype(int) - neutral[:, SIZE:].astype(int)).sum(axis=2)
    assert (diff > 30).mean() > 0.02
    # the face's own left is the viewer's right: the face's pixels shift right
    skin_n = neutral[:, SIZE:, 0].astype(int) - neutral[:, SIZE:, 2] > 40
    skin_t = turned[:, SIZE:, 0].astype(int) - turned[:, SIZE:, 2] > 40
    upper = slice(SIZE // 4, SIZE // 2)
    assert _centroid(skin_t[upper])[0] > _centroid(skin_n[upper])[0] + 2


def test_eyebrow_raise_moves_brow_pixels_up():
    neutral, _ = _frame([_track()])
    raised, _ = _frame([_track(f31=250, f32=250, f33=250, f34=250, f35=250, f36=250)])
    band = slice(int(SIZE * 0.2), int(SIZE * 0.36))  # above the lashes and pupils

    def brow(img):
        region = img[band]
        return (region.astype(int).sum(axis=2) < 260) & (region[..., 0] > region[..., 2])

    assert _centroid(brow(raised))[1] < _centroid(brow(neutral))[1] - 1.5


def test_gaze_moves_the_pupils():
    neutral, _ = _frame([_track()])
    looked, _ = _frame([_track(f23=25000, f24=25000)])  # 0.25 rad: the pupils move ~2.4 px
    eyes = slice(int(SIZE * 0.392), int(SIZE * 0.45))  # below the lashes, which stay
    for half in (slice(0, SIZE // 2), slice(SIZE // 2, SIZE)):  # each eye on its own
        pupils_n, pupils_l = _dark(neutral[eyes, half], 40), _dark(looked[eyes, half], 40)
        assert pupils_n.sum() > 4 and pupils_l.sum() > 4
        # yaw positive = to the face's left = the viewer's right
        assert _centroid(pupils_l)[0] > _centroid(pupils_n)[0] + 1.2


def test_jaw_opens_the_mouth_before_the_mosaic():
    neutral, _ = _frame([_track()])
    opened, _ = _frame([_track(f3=500)])
    mouth = slice(int(SIZE * 0.55), int(SIZE * 0.8))
    assert _dark(opened[mouth]).sum() > _dark(neutral[mouth]).sum() + 100


def test_mosaic_blocks_are_constant_on_raw_frames():
    t = np.arange(12) / 30.0
    a = MotionTrack.from_channels(30.0, {3: 300 + 300 * np.sin(9 * t), 49: 15000 * t})
    b = MotionTrack.from_channels(30.0, {3: 200 + 200 * np.sin(5 * t)})
    block = 16
    gen = render_frames(
        [a, b],
        builtin_face(),
        size=SIZE,
        samples=4,
        background=(0.5, 0.5, 0.5),
        mosaic_block=block,
        mosaic_margin=0.15,
    )
    n = 0
    for fr in gen:
        assert len(fr.boxes) == 2 == len(fr.cells)
        for (x0, y0, x1, y1), blocks in zip(fr.boxes, fr.cells, strict=True):
            assert x1 > x0 and y1 > y0 and blocks.shape == ((y1 - y0) // block, (x1 - x0) // block)
            cells = fr.image[y0:y1, x0:x1].reshape(
                (y1 - y0) // block, block, (x1 - x0) // block, block, 3
            )
            # constant on the face; background pixels beside it are left alone
            face = (cells != 128).any(axis=-1)
            same = (
                cells == cells.max(axis=(1, 3), where=face[..., None], initial=0)[:, None, :, None]
            ).all(axis=-1)
            # the blocks reach past the chin and cheek as far as the clip's jaw moves them
            by_cell = (same | ~face).transpose(0, 2, 1, 3), face.transpose(0, 2, 1, 3)
            assert by_cell[0][blocks].all() and by_cell[1][blocks].mean() > 0.6
            assert blocks.sum() > 4
        n += 1
    assert n == 12


def test_align_tracks_brings_the_second_track_to_the_first():
    a = MotionTrack.zeros(30.0, 30, (3,))
    b = MotionTrack.zeros(60.0, 40, (3,))
    out = align_tracks([a, b], None)
    assert [t.fps for t in out] == [30.0, 30.0] and [t.n_frames for t in out] == [30, 30]


def test_worker_processes_draw_the_same_frames_in_order(monkeypatch):
    import renderer.pipeline as pipeline

    monkeypatch.setattr(pipeline, "PARALLEL_MIN_FRAMES", 1)
    monkeypatch.setattr(pipeline, "CHUNK_FRAMES", 2)
    n = 25  # the shared ring holds (2 * workers + 1) chunks = 10 frames: slots are reused
    t = np.arange(n) / 30.0
    a = MotionTrack.from_channels(30.0, {49: 20000 * np.sin(4 * t), 3: 300 * t})
    b = MotionTrack.from_channels(30.0, {48: 15000 * np.sin(3 * t)})
    kwargs = dict(size=64, samples=4, mosaic_block=8, mosaic_margin=0.15)
    serial = [
        (f.index, f.image.copy(), f.boxes) for f in render_frames([a, b], builtin_face(), **kwargs)
    ]
    parallel = [
        (f.index, f.image.copy(), f.boxes)
        for f in render_frames([a, b], builtin_face(), workers=2, **kwargs)
    ]
    assert [i for i, _, _ in parallel] == list(range(n))
    for (i, img, boxes), (j, img2, boxes2) in zip(serial, parallel, strict=True):
        assert i == j and boxes == boxes2 and np.array_equal(img, img2)
    assert not np.array_equal(serial[0][1], serial[-1][1])  # the frames do differ


def _shared_segments():
    from pathlib import Path

    shm = Path("/dev/shm")
    return {p.name for p in shm.glob("psm_*")}  # SharedMemory's names


def test_worker_frames_outlive_the_ring_and_nothing_is_left_behind(monkeypatch):
    import renderer.pipeline as pipeline

    monkeypatch.setattr(pipeline, "PARALLEL_MIN_FRAMES", 1)
    frame_bytes = 64 * 128 * 3
    monkeypatch.setattr(pipeline, "RING_BYTES", 3 * frame_bytes)  # 3 frames: 1 chunk ahead
    n = 7
    t = np.arange(n) / 30.0
    a = MotionTrack.from_channels(30.0, {49: 20000 * np.sin(4 * t)})
    b = MotionTrack.from_channels(30.0, {48: 15000 * np.sin(3 * t)})
    kwargs = dict(size=64, mosaic_block=8, mosaic_margin=0.15)
    serial = [f.image.copy() for f in render_frames([a, b], builtin_face(), **kwargs)]
    before = _shared_segments()
    kept = list(render_frames([a, b], builtin_face(), workers=2, **kwargs))
    # the ring is gone; the frames kept are readable (the last one, as on the serial path)
    assert [f.index for f in kept] == list(range(n))
    assert np.array_equal(kept[-1].image, serial[-1])
    gen = render_frames([a, b], builtin_face(), workers=2, **kwargs)
    first = next(gen)
    gen.close()  # stopped early
    assert np.array_equal(first.image, serial[0])
    assert _shared_segments() <= before


def test_the_mosaic_carries_no_mouth_opening():
    # the jaw opens and closes while the head turns and nods, beside the same head with its
    # jaw still: every frame of the two is the same picture (a mosaic of the frame itself
    # darkens as the mouth opens: its mean luminance correlates about -0.9 with the jaw)
    n = 40
    t = np.arange(n) / 30.0
    jaw = 300 + 300 * np.sin(2 * np.pi * 1.3 * t)
    head = {49: 30000 * np.sin(2 * np.pi * 0.4 * t), 48: 5000 * np.sin(2 * np.pi * 0.7 * t)}
    talking = MotionTrack.from_channels(30.0, {3: jaw, **head})
    silent = MotionTrack.from_channels(30.0, head)
    kwargs = dict(size=128, mosaic_margin=0.15)
    shown = render_frames([talking, silent], builtin_face(), mosaic_block=8, **kwargs)
    plain = render_frames([talking, silent], builtin_face(), mosaic_block=0, **kwargs)
    opened = 0
    for fr, raw in zip(shown, plain, strict=True):
        assert np.array_equal(fr.image[:, :128], fr.image[:, 128:])
        x0, y0, x1, y1 = fr.boxes[0]
        opened += not np.array_equal(raw.image[y0:y1, x0:x1], raw.image[y0:y1, 128 + x0 : 128 + x1])
    assert opened == n  # without the mosaic the mouth shows in every frame


def test_the_mosaic_does_not_spill_onto_the_background():
    track = _track(f49=60000, f3=400)  # head turned 34 degrees: the box reaches past the cheek
    plain, _ = _frame([_track(f49=60000)], mosaic_block=0)  # the mouth at rest, as drawn
    mosaicked, boxes = _frame([track], mosaic_block=16)
    x0, y0, x1, y1 = boxes[0]
    background = (plain == [140, 143, 148]).all(axis=2)
    assert background[y0:y1, x0:x1].sum() > 50  # the case this is about
    assert np.array_equal(mosaicked[background], plain[background])


@pytest.mark.parametrize("antialias", ["edges", "msaa"])
def test_two_faces_that_differ_only_in_the_mouth_are_the_same_picture(antialias):
    # two conditions alike but for the mouth, side by side: the same box (the region both
    # clips' mouths move through) and the same pixels, inside the mosaic and out
    pose = dict(f49=25000, f48=-6000, f31=150, f32=150)
    still, moving = _track(**pose), _track(**pose, f3=400, f5=-150, f12=120, f13=120, f53=90)
    image, boxes = _frame([still, moving], mosaic_block=16, antialias=antialias)
    (x0, y0, x1, y1), right = boxes
    assert right == (x0 + SIZE, y0, x1 + SIZE, y1)
    assert np.array_equal(image[:, :SIZE], image[:, SIZE:])
    alone, alone_boxes = _frame([still], mosaic_block=16, antialias=antialias)
    # drawn alone, the still face's box is its mouth at rest only: smaller, the chin free
    assert alone_boxes[0][3] < boxes[0][3]


def test_workers_start_with_single_threaded_blas_and_a_set_value_is_kept(monkeypatch):
    from renderer import pipeline

    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    with pipeline._single_threaded_blas():
        assert os.environ["OPENBLAS_NUM_THREADS"] == "1"
        assert os.environ["OMP_NUM_THREADS"] == "3"
    assert "OPENBLAS_NUM_THREADS" not in os.environ
    assert os.environ["OMP_NUM_THREADS"] == "3"
