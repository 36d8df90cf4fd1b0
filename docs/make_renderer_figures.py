"""Make the renderer's figures in docs/img: the built-in face, a side-by-side frame, and the
same frame drawn on a glTF avatar; and in docs/figures the built-in head's two looks side by
side (plain, per-vertex colour, against textured, the default), whole and around the eyes.

    python docs/make_renderer_figures.py

The pair frame is frame 45 of the demo speech (app/data/demo/speech.wav): speech-driven prosody on
the left, Perlin-noise prosody on the right, mouths hidden by the default mosaic. The avatar
frame draws them on the built-in head exported as glTF (``facepair face export``), through
the ARKit blendshapes and bones an avatar is driven by. The contact sheets of extreme poses
(docs/img/extreme-poses*.png) show the built-in head over the pose box a capture reaches with
the jaw closed, half open and fully open, with and without the mosaic.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from app.stimuli.generate import generate_conditions
from app.stimuli.track import MotionTrack
from renderer import RenderSettings, render_still
from renderer.faceexport import export_builtin_head

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "img"
FIGURES = ROOT / "docs" / "figures"


def looks_side_by_side() -> list[Path]:
    """The plain and the textured head, neutral and mouth shown: whole at 368 px, and the eyes
    and brows of a 736 px drawing at twice that (every pixel a 2x2 block)."""
    import imageio.v3 as iio

    FIGURES.mkdir(parents=True, exist_ok=True)
    still = {}
    for size in (368, 736):
        for look in ("plain", "textured"):
            with tempfile.TemporaryDirectory() as tmp:
                path = render_still(
                    MotionTrack.zeros(30.0, 1),
                    0,
                    Path(tmp) / "a.png",
                    settings=RenderSettings(size=size, look=look),
                    mosaic=False,
                )
                still[size, look] = iio.imread(path)
    gap = np.full((368, 8, 3), 255, np.uint8)
    whole = np.hstack([still[368, "plain"], gap, still[368, "textured"]])
    eyes = [
        still[736, look][196:346, 196:540].repeat(2, 0).repeat(2, 1)
        for look in ("plain", "textured")
    ]
    close = np.vstack([eyes[0], np.full((8, eyes[0].shape[1], 3), 255, np.uint8), eyes[1]])
    out = [FIGURES / "head-plain-textured.png", FIGURES / "head-plain-textured-eyes.png"]
    iio.imwrite(out[0], whole)
    iio.imwrite(out[1], close)
    return out


#: The contact sheet's poses (yaw, pitch, roll in degrees; pitch > 0 bows the head): the
#: corners of the box a capture reaches, a 20 degree roll and the crown seen from above.
EXTREME_POSES = ((-35, -20, 0), (35, -20, 15), (35, 20, -15), (0, 0, 20), (0, 20, 0))
EXTREME_JAWS = (0, 350, 1024)


def extreme_poses(size: int = 256) -> list[Path]:
    """Contact sheets of the built-in head at the extremes: rows the jaw closed, at 350 (what
    the synthetic ground truth reaches) and at 1024 (its full range), columns the poses of
    :data:`EXTREME_POSES`; one with the mouth shown, one with the default mosaic (each cell a
    clip of its own, so the mosaic covers that clip's jaw)."""
    import imageio.v3 as iio

    from renderer.pipeline import render_frames

    unit = np.radians(1.0) / 1e-5  # FAP units (1e-5 rad) per degree
    out = []
    for name, block in (("extreme-poses.png", 0), ("extreme-poses-mosaic.png", 16)):
        rows = []
        for jaw in EXTREME_JAWS:
            cells = []
            for yaw, pitch, roll in EXTREME_POSES:
                track = MotionTrack.from_channels(
                    30.0,
                    {
                        3: np.array([float(jaw)]),
                        48: np.array([pitch * unit]),
                        49: np.array([yaw * unit]),
                        50: np.array([roll * unit]),
                    },
                )
                frames = render_frames(
                    [track], load_builtin(), size=size, mosaic_block=block, mosaic_margin=0.15
                )
                cells.append(next(frames).image.copy())
                frames.close()
                cells.append(np.full((size, 4, 3), 255, np.uint8))
            rows.append(np.hstack(cells[:-1]))
            rows.append(np.full((4, rows[-1].shape[1], 3), 255, np.uint8))
        path = OUT / name
        iio.imwrite(path, np.vstack(rows[:-1]))
        out.append(path)
    return out


#: The avatar contact sheet's columns: the built-in head, then the structures other tools
#: write (tests/renderer/avatar_fixtures.py), then the head exported and read back.
AVATAR_COLUMNS = ("built-in", "facecap", "rpm", "vroid", "vrm1", "mixamo", "eyes as meshes")


def avatar_structures(size: int = 224) -> Path:
    """Contact sheet of the avatar structures: top row every morph weight 0 (the frame that
    drew black before), bottom row frame 45 of the demo ground truth under the mosaic."""
    import imageio.v3 as iio

    from app.stimuli.io import load_track
    from tests.renderer.avatar_fixtures import build_avatar, build_eye_mesh_only

    track = load_track(ROOT / "app" / "data" / "demo" / "ground_truth.fap")
    rows: list[list[np.ndarray]] = [[], []]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for column in AVATAR_COLUMNS:
            face = None
            if column == "eyes as meshes":
                face = build_eye_mesh_only(folder)
            elif column != "built-in":
                face = build_avatar(column, folder)
            settings = RenderSettings(size=size, face=str(face) if face else None)
            for row, (frame, mosaic) in enumerate(((0, False), (45, True))):
                still = folder / "s.png"
                path = render_still(track, frame, still, settings=settings, mosaic=mosaic)
                rows[row].append(iio.imread(path))
                rows[row].append(np.full((size, 4, 3), 255, np.uint8))
    top, bottom = (np.hstack(r[:-1]) for r in rows)
    sheet = np.vstack([top, np.full((4, top.shape[1], 3), 255, np.uint8), bottom])
    out = OUT / "avatar-structures.png"
    iio.imwrite(out, sheet)
    return out


def load_builtin():
    from renderer.headmodel import builtin_face

    return builtin_face()


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    settings = RenderSettings()
    face = render_still(
        MotionTrack.zeros(30.0, 1), 0, OUT / "face.png", settings=settings, mosaic=False
    )
    result = generate_conditions(
        ROOT / "app" / "data" / "demo" / "speech.wav", conditions=("speech_driven", "random")
    )
    pair = render_still(
        result.tracks["speech_driven"],
        45,
        OUT / "pair.png",
        right=result.tracks["random"],
        settings=settings,
    )
    with tempfile.TemporaryDirectory() as tmp:
        avatar = RenderSettings(face=str(export_builtin_head(Path(tmp) / "head.glb")))
        on_avatar = render_still(
            result.tracks["speech_driven"],
            45,
            OUT / "avatar-pair.png",
            right=result.tracks["random"],
            settings=avatar,
        )
    print(face)
    print(pair)
    print(on_avatar)
    for path in looks_side_by_side():
        print(path)
    for path in extreme_poses():
        print(path)
    print(avatar_structures())


if __name__ == "__main__":
    main()
