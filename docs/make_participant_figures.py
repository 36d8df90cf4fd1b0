"""Make the participant's trial-page screenshots in docs/figures from the real demo clips.

    PYTHONPATH=. python docs/make_participant_figures.py

Renders one demo pair (app/data/demo/speech.wav: speech-driven prosody on the left, Perlin-noise
prosody on the right) with ``renderer.render_pair``, then runs the browser test that puts that
clip on the trial page at desktop (1366x768) and phone (390x844) size and checks its layout
(tests/web/test_browser_participant.py::test_trial_page_layout_and_screenshots), saving
participant-trial-desktop.png and participant-trial-phone.png here; then the same clip in a
German and an Arabic (right-to-left) study, and the audio check before the first trial, at
desktop size (tests/web/participant/test_language_browser.py): participant-trial-german-desktop.png,
participant-trial-arabic-desktop.png and participant-audio-check-desktop.png. Then renders one face
(speech-driven prosody, ``renderer.render_single``) and runs the rating design's layout test
(tests/web/test_browser_rating.py::test_rating_page_layout_and_screenshots) for
participant-rating-desktop.png (the five ACR levels) and participant-rating-phone.png (the
slider), and the parallel design's test for participant-parallel-desktop.png and -phone.png.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

from app.stimuli.generate import generate_conditions
from renderer import render_pair, render_single

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "figures"


def main() -> None:
    speech = ROOT / "app" / "data" / "demo" / "speech.wav"
    result = generate_conditions(speech, conditions=("speech_driven", "random"))
    with tempfile.TemporaryDirectory() as tmp:
        clip = render_pair(
            result.tracks["speech_driven"], result.tracks["random"], speech, Path(tmp) / "pair.mp4"
        )
        single = render_single(result.tracks["speech_driven"], speech, Path(tmp) / "single.mp4")
        env = {
            **os.environ,
            "FACEPAIR_DEMO_CLIP": str(clip),
            "FACEPAIR_DEMO_CLIP_SINGLE": str(single),
            "FACEPAIR_SCREENSHOTS": str(OUT),
        }
        for tests in (
            [
                "tests/web/test_browser_participant.py::test_trial_page_layout_and_screenshots",
                "tests/web/participant/test_language_browser.py",
                "-k",
                "desktop or layout_and_screenshots",
            ],
            [
                "tests/web/test_browser_rating.py::test_rating_page_layout_and_screenshots",
                "tests/web/test_browser_rating.py::test_a_participant_rates_every_version_in_parallel",
            ],
        ):
            pytest = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"]
            subprocess.run([*pytest, *tests], cwd=ROOT, env=env, check=True)
    print(OUT / "participant-trial-desktop.png")
    print(OUT / "participant-trial-phone.png")
    for name in ("trial-german", "trial-arabic", "audio-check"):
        print(OUT / f"participant-{name}-desktop.png")
    print(OUT / "participant-rating-desktop.png")
    print(OUT / "participant-rating-phone.png")
    print(OUT / "participant-parallel-desktop.png")
    print(OUT / "participant-parallel-phone.png")


if __name__ == "__main__":
    main()
