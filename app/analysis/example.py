"""The example study shipped in ``app/data/examples/votes.csv`` (simulated; see its README).

Regenerate with ``python -m app.analysis.example app/data/examples/votes.csv``.
"""

from __future__ import annotations

import sys
from typing import Any

from app.analysis.simulate import simulate_votes
from app.analysis.votes import write_votes_csv

#: True Case V scale (JOD) of the simulated study; thesis condition names (app.stimuli).
TRUE_SCALE = {"none": -0.8, "random": 0.1, "speech_driven": 0.35, "ground_truth": 0.6}
EXAMPLE: dict[str, Any] = {
    "participants": 14,
    "clips": ("s2", "s7"),
    "undecided_width": 0.3,
    "seed": 2005,
    "study": "example",
}


def main(path: str) -> None:
    votes = simulate_votes(TRUE_SCALE, **EXAMPLE)
    write_votes_csv(votes, path)


if __name__ == "__main__":
    main(sys.argv[1])
