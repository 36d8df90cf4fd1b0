"""Make the renderer's figures in docs/img: the built-in face, a side-by-side frame, and the
same frame drawn on a glTF avatar; and in docs/figures the built-in head's two looks side by
side (plain, per-vertex colour, against textured, the default), whole and around the eyes.

    python docs/make_renderer_figures.py

The pair frame is frame 45 of the demo speech (app/data/demo/speech.wav): speech-driven prosody on
the left, Perlin-noise prosody on the right, mouths hidden by the default mosaic. The avatar
frame draws them on the built-in head exported as glTF (``facepair face export``), through
the ARKit blendshapes and bones an avatar is driven by.
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


if __name__ == "__main__":
    main()
