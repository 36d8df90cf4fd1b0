"""Make the participant's trial-page screenshots in docs/figures from the real demo clip.

    PYTHONPATH=. python docs/make_participant_figures.py

Renders one demo pair (app/data/demo/speech.wav: speech-driven prosody on the left, Perlin-noise
prosody on the right) with ``renderer.render_pair``, then runs the browser test that puts that
clip on the trial page at desktop (1366x768) and phone (390x844) size and checks its layout
(tests/test_browser_participant.py::test_trial_page_layout_and_screenshots), saving
participant-trial-desktop.png and participant-trial-phone.png here; then the same clip in a
German and an Arabic (right-to-left) study, and the audio check before the first trial, at
desktop size (tests/participant/test_language_browser.py): participant-trial-german-desktop.png,
participant-trial-arabic-desktop.png and participant-audio-check-desktop.png.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

from app.stimuli.generate import generate_conditions
from renderer import render_pair

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "figures"


def main() -> None:
    speech = ROOT / "app" / "data" / "demo" / "speech.wav"
    result = generate_conditions(speech, conditions=("speech_driven", "random"))
    with tempfile.TemporaryDirectory() as tmp:
        clip = render_pair(
            result.tracks["speech_driven"], result.tracks["random"], speech, Path(tmp) / "pair.mp4"
        )
        env = {**os.environ, "FACEPAIR_DEMO_CLIP": str(clip), "FACEPAIR_SCREENSHOTS": str(OUT)}
        subprocess.run(
            [
                sys.executable,
                "-m",
                "pytest",
                "-q",
                "-p",
                "no:cacheprovider",
                "tests/test_browser_participant.py::test_trial_page_layout_and_screenshots",
                "tests/participant/test_language_browser.py",
                "-k",
                "desktop or layout_and_screenshots",
            ],
            cwd=ROOT,
            env=env,
            check=True,
        )
    print(OUT / "participant-trial-desktop.png")
    print(OUT / "participant-trial-phone.png")
    for name in ("trial-german", "trial-arabic", "audio-check"):
        print(OUT / f"participant-{name}-desktop.png")


if __name__ == "__main__":
    main()
