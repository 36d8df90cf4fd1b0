"""Make the experimenter's screenshots in docs/figures (and the questionnaire page's).

    PYTHONPATH=. python docs/make_experimenter_figures.py

Runs the browser tests that walk the experimenter's side end to end
(tests/web/test_browser_experimenter.py: a study made on the form, piloted, opened, taken by two
participants, one of them left out for a failed catch trial) and every page type through
axe-core (tests/web/test_browser_axe.py, which shoots the questionnaire page at phone size), with
their screenshots in a temporary folder, and copies the ones the docs show here:
experimenter-study.png, experimenter-monitor.png and participant-questionnaire.png.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "figures"
#: The screenshot each test writes -> its name in docs/figures.
FIGURES = {
    "experimenter-study-open.png": "experimenter-study.png",
    "experimenter-monitor-participants.png": "experimenter-monitor.png",
    "participant-questionnaire.png": "participant-questionnaire.png",
}
TESTS = (
    "tests/web/test_browser_experimenter.py::test_an_experimenter_runs_a_study_from_start_to_end",
    "tests/web/test_browser_axe.py::test_every_page_type_passes_axe",
)


def main() -> None:
    with tempfile.TemporaryDirectory() as shots:
        env = {**os.environ, "FACEPAIR_SCREENSHOTS": shots}
        command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *TESTS]
        subprocess.run(command, cwd=ROOT, env=env, check=True)
        for shot, figure in FIGURES.items():
            shutil.copyfile(Path(shots) / shot, OUT / figure)
            print(OUT / figure)


if __name__ == "__main__":
    main()
