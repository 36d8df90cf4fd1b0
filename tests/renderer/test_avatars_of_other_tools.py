"""Avatars as other tools make them (tests/renderer/avatar_fixtures.py: three.js's Face Cap
head, Ready Player Me, VRoid, VRM 1.0, Mixamo, eyes as meshes only; the project's own export,
plain and packed by gltfpack with a KTX2 texture): each loads without a mapping file, renders
lit with no black face pixel in any frame, and keeps its eyes and brows out of the mosaic while
no jaw or lip motion shows outside it, over the pose grid the built-in head is tested on
(tests/renderer/test_mouthregion.py)."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from app.cli import main
from app.stimuli.track import MotionTrack
from renderer.avatar import AvatarRig, load_avatar
from renderer.camera import camera_for, project
from renderer.pipeline import render_frames
from tests.renderer.avatar_fixtures import (
    EYE_NAMES,
    KINDS,
    build_avatar,
    build_eye_mesh_only,
    structure,
)

pytestmark = pytest.mark.gl
SIZE = 128
BLOCK = 8
BACKGROUND = (0.55, 0.56, 0.58)
DEG = np.radians(1.0) / 1e-5
POSES = [(0, 0, 0), *itertools.product((-35, 35), (-20, 20), (-15, 15))]
#: the jaw opened with the lips, as the built-in head's mosaic test opens it
MOUTH = {3: 350, 5: -150, 6: 80, 7: 80, 12: 120, 13: 120, 53: 90, 55: -60, 56: -60}
#: a frame of brows, blinks and gaze with the mouth at rest
UPPER = {31: 60, 32: 60, 33: 40, 34: 40, 19: 80, 20: 80, 23: 15000, 24: 15000}
#: a pixel counts as changed beyond this difference in a channel (of 255)
SHOWS = 6
ALL = (*KINDS, "eyes as meshes", "exported", "gltfpack + KTX2")


@pytest.fixture(scope="module")
def avatars(tmp_path_factory, exported_head) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("avatars")
    out = {kind: build_avatar(kind, folder) for kind in KINDS}
    out["eyes as meshes"] = build_eye_mesh_only(folder)
    out["exported"] = exported_head
    # the export packed by gltfpack (meshopt, quantised, a KTX2 texture; no extras, so its
    # mouth is found from its shapes): tests/renderer/data/make_compressed_avatars.py
    out["gltfpack + KTX2"] = Path(__file__).parent / "data" / "head-ktx2.glb"
    return out


def _track(frames: list[dict[int, float]]) -> MotionTrack:
    faps = sorted({f for frame in frames for f in frame})
    return MotionTrack.from_channels(
        30.0, {f: np.array([frame.get(f, 0.0) for frame in frames]) for f in faps}
    )


def _render(face, frames, block):
    kwargs = dict(size=SIZE, background=BACKGROUND, mosaic_block=block, mosaic_margin=0.15)
    return [(f.image.copy(), _blocks(f)) for f in render_frames([_track(frames)], face, **kwargs)]


def _blocks(frame) -> np.ndarray:
    inside = np.zeros(frame.image.shape[:2], bool)
    for (x0, y0, x1, y1), cells in zip(frame.boxes, frame.cells, strict=True):
        inside[y0:y1, x0:x1] = np.repeat(np.repeat(cells, BLOCK, 0), BLOCK, 1)
    return inside


def _region(rig: AvatarRig, frame_faps: dict[int, float], vertices: np.ndarray) -> np.ndarray:
    """The pixels (y, x) of ``vertices`` posed as ``frame_faps`` poses them."""
    faps = np.zeros(68)
    for k, v in frame_faps.items():
        faps[k - 1] = v
    pos, _ = rig.posed(rig.deform(faps))
    vp, _ = camera_for(rig)
    xy = project(vp, pos[vertices].astype(np.float64), SIZE)
    return np.round(xy[:, ::-1]).astype(int)


@pytest.mark.parametrize("kind", [*KINDS, "eyes as meshes"])
def test_each_structure_loads_without_a_mapping_file(avatars, kind):
    avatar = load_avatar(avatars[kind])
    assert avatar.eye_pivots["l"][0] > avatar.eye_pivots["r"][0]  # the character's left: +x
    assert len(avatar.groups["eyeball_l"]) and len(avatar.groups["eyeball_r"])
    es = np.linalg.norm(avatar.feature_points["3.5"] - avatar.feature_points["3.6"])
    assert 0.055 < es < 0.07, es  # the head's own pupils, 62 mm apart, whatever the bones
    mouth_y = avatar.feature_points["2.3"][1]
    assert -0.085 < mouth_y < -0.05, mouth_y  # the lower lip, not a chest or a hand


@pytest.mark.parametrize("convention", sorted(EYE_NAMES))
@pytest.mark.parametrize("kind", ["rpm", "facecap"])
def test_every_eye_naming_convention_is_recognised(tmp_path, kind, convention):
    path = build_avatar(kind, tmp_path, eye_names=EYE_NAMES[convention])
    avatar = load_avatar(path)
    assert avatar.eye_pivots["l"][0] > 0.02 and avatar.eye_pivots["r"][0] < -0.02
    assert avatar.eyes_found.startswith("by name"), avatar.eyes_found


@pytest.mark.parametrize("kind", ALL)
def test_every_frame_is_lit_and_no_face_pixel_is_black(avatars, kind):
    """The bug: a frame whose morph weights are all 0 was drawn pure black, eyes black holes."""
    avatar = load_avatar(avatars[kind])
    frames = [{49: 0.0}, {49: 12 * DEG, 48: 8 * DEG}, {**MOUTH, **UPPER}]
    rig = AvatarRig(avatar)
    eyes = np.concatenate([avatar.groups["eyeball_l"], avatar.groups["eyeball_r"]])
    bg = np.round(np.array(BACKGROUND) * 255).astype(int)
    for faps, (image, _) in zip(frames, _render(avatar, frames, 0), strict=True):
        face = np.abs(image.astype(int) - bg).max(axis=2) > 3
        lum = image[face].astype(float).mean()
        assert 90 < lum < 230, (kind, faps, lum)  # the built-in head: about 140
        pupils = np.zeros(face.shape, bool)
        for y, x in _region(rig, faps, eyes):
            pupils[max(y - 2, 0) : y + 3, max(x - 2, 0) : x + 3] = True
        black = face & ~pupils & (image.max(axis=2) <= 4)  # (0, 0, 0) was the defect
        assert not black.any(), (kind, faps, int(black.sum()))


@pytest.mark.parametrize("kind", ALL)
def test_the_mosaic_hides_the_mouth_and_leaves_the_eyes_and_brows(avatars, kind):
    avatar = load_avatar(avatars[kind])
    rig = AvatarRig(avatar)
    eyes = np.concatenate([avatar.groups["eyeball_l"], avatar.groups["eyeball_r"]])
    # the brows: what the brow-raising shapes move most
    lift = sum(np.linalg.norm(avatar.targets[k][0], axis=1) for k in avatar.targets if "Brow" in k)
    brows = np.flatnonzero(lift > 0.5 * lift.max())
    assert len(brows) > 10
    upper = np.concatenate([eyes, brows]).astype(int)
    for yaw, pitch, roll in POSES:
        pose = {49: yaw * DEG, 48: pitch * DEG, 50: roll * DEG}
        frames = [pose, {**pose, **MOUTH}]
        (closed, _), (opened, _) = _render(avatar, frames, 0)
        (_, inside), (mosaic_open, inside_open) = _render(avatar, frames, BLOCK)
        assert np.array_equal(inside, inside_open)  # the blocks follow the head, not the mouth
        changed = (np.abs(closed.astype(int) - opened.astype(int)) > SHOWS).any(axis=2)
        assert changed.sum() > 20 or kind == "vroid", (kind, pose)  # the jaw opens
        shown = changed & ~inside
        assert not shown.any(), (kind, pose, int(shown.sum()))
        ys, xs = _region(rig, pose, upper).T
        ok = (ys >= 0) & (ys < SIZE) & (xs >= 0) & (xs < SIZE)
        covered = inside[ys[ok], xs[ok]]
        assert not covered.any(), (kind, pose, int(covered.sum()))


@pytest.mark.parametrize("kind", ALL)
def test_the_cli_renders_a_still_and_a_pair_clip_of_each(avatars, kind, tmp_path, tone_wav):
    track = tmp_path / "t.csv"
    track.write_text("# fps=30\nframe,fap3,fap49,fap31\n0,0,0,0\n1,300,2000,40\n2,0,4000,0\n")
    face = str(avatars[kind])
    still = CliRunner().invoke(
        main,
        ["render", "still", "--track", str(track), "--face", face, "--size", "64"]
        + ["--frame", "1", "--out", str(tmp_path / "s.png")],
    )
    assert still.exit_code == 0, still.output
    pair = CliRunner().invoke(
        main,
        ["render", "pair", "--left", str(track), "--right", str(track), "--face", face]
        + ["--audio", str(tone_wav(0.1)), "--size", "64", "--out", str(tmp_path / "p.mp4")],
    )
    assert pair.exit_code == 0, pair.output
    assert (tmp_path / "p.mp4").stat().st_size > 1000


def test_the_structures_are_described():
    assert all(structure(k) for k in KINDS)
