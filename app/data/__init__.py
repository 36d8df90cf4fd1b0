"""Files that ship inside the facepair package: the demo speech and study, the default models,
the simulated example votes.

They are package data, read through :mod:`importlib.resources`, so a checkout and an installed
wheel find them alike (``facepair demo`` and default-model stimuli work outside the repository).

>>> data_path("models", "head_arx_default.json").name
'head_arx_default.json'
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def data_path(*parts: str) -> Path:
    """The file system path of a file under ``app/data`` (``parts`` as in ``"demo", "speech.wav"``).

    Wheels install unzipped, so the resource is a real file that numpy, Praat and ffmpeg open.
    """
    return Path(str(files(__name__).joinpath("/".join(parts))))
