"""Make the renderer's figures in docs/img: the built-in face and a side-by-side frame.

    python docs/make_renderer_figures.py

The pair frame is frame 45 of the demo speech (data/demo/speech.wav): speech-driven prosody on
the left, Perlin-noise prosody on the right, mouths hidden by the default mosaic.
"""

from __future__ import annotations

from pathlib import Path

from app.stimuli.generate import generate_conditions
from app.stimuli.track import MotionTrack
from renderer import RenderSettings, render_still

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "img"


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    settings = RenderSettings()
    face = render_still(MotionTrack.zeros(30.0, 1), 0, OUT / "face.png", settings=settings,
                        mosaic=False)
    result = generate_conditions(ROOT / "data" / "demo" / "speech.wav",
                                 conditions=("speech_driven", "random"))
    pair = render_still(result.tracks["speech_driven"], 45, OUT / "pair.png",
                        right=result.tracks["random"], settings=settings)
    print(face)
    print(pair)


if __name__ == "__main__":
    main()
