"""Make the renderer's figures in docs/img: the built-in face, a side-by-side frame, and the
same frame drawn on a glTF avatar.

    python docs/make_renderer_figures.py

The pair frame is frame 45 of the demo speech (app/data/demo/speech.wav): speech-driven prosody on
the left, Perlin-noise prosody on the right, mouths hidden by the default mosaic. The avatar
frame draws them on the built-in head exported as glTF (``facepair face export``), through
the ARKit blendshapes and bones an avatar is driven by.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from app.stimuli.generate import generate_conditions
from app.stimuli.track import MotionTrack
from renderer import RenderSettings, render_still
from renderer.faceexport import export_builtin_head

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "img"


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    settings = RenderSettings()
    face = render_still(MotionTrack.zeros(30.0, 1), 0, OUT / "face.png", settings=settings,
                        mosaic=False)
    result = generate_conditions(ROOT / "app" / "data" / "demo" / "speech.wav",
                                 conditions=("speech_driven", "random"))
    pair = render_still(result.tracks["speech_driven"], 45, OUT / "pair.png",
                        right=result.tracks["random"], settings=settings)
    with tempfile.TemporaryDirectory() as tmp:
        avatar = RenderSettings(face=str(export_builtin_head(Path(tmp) / "head.glb")))
        on_avatar = render_still(result.tracks["speech_driven"], 45, OUT / "avatar-pair.png",
                                 right=result.tracks["random"], settings=avatar)
    print(face)
    print(pair)
    print(on_avatar)


if __name__ == "__main__":
    main()
