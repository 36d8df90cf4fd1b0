"""Ground truth from capture: trackers' files (OpenFace 2.0, ARKit / Live Link Face) to FAPs,
and the thesis' own marker pipeline from IR video (:mod:`~app.stimuli.capture.markers`).

:func:`sniff_csv` tells a tracker's CSV from facepair's own track CSV by its header, so every
place that reads a ground truth (``stimuli generate --ground-truth``, study files, the web
generate job) takes these files as they are. Mappings, units and signs: the importer modules
and docs/capture.md.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import TYPE_CHECKING

from app.errors import InputError

if TYPE_CHECKING:
    from app.stimuli.track import MotionTrack

#: Tracker formats facepair imports.
FORMATS = ("openface", "arkit")


def sniff_csv(path: str | Path) -> str | None:
    """``"openface"``, ``"arkit"`` or ``None`` (not a tracker file) from the header line."""
    from app.stimuli.capture.arkit import is_arkit
    from app.stimuli.capture.openface import is_openface

    try:
        with Path(path).open(newline="", encoding="utf-8-sig") as f:
            first = f.readline(65536)
    except (OSError, UnicodeDecodeError):
        return None
    header = [h.strip() for h in next(csv.reader([first], skipinitialspace=True), [])]
    if is_openface(header):
        return "openface"
    if is_arkit(header):
        return "arkit"
    return None


def import_track(path: str | Path, kind: str | None = None, fps: float = 30.0) -> MotionTrack:
    """Read a tracker file as a FAP track at ``fps``; ``kind`` None detects it."""
    from app.stimuli.capture.arkit import read_arkit_csv
    from app.stimuli.capture.openface import read_openface

    kind = kind or sniff_csv(path)
    if kind == "openface":
        return read_openface(path, fps)
    if kind == "arkit":
        return read_arkit_csv(path, fps)
    raise InputError(
        f"not a tracker file facepair imports ({', '.join(FORMATS)}): its "
        "header is neither OpenFace's nor Live Link Face's",
        path=path,
        line=1,
    )
