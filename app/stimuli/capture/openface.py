"""OpenFace 2.0 FeatureExtraction CSV -> FAP track (head, gaze, eyebrows, eyelids, jaw).

The file (``RecorderCSV`` in OpenFace 2.x) starts ``frame, face_id, timestamp, confidence,
success`` and then, as the tracker was asked, ``gaze_0_x ... gaze_angle_x, gaze_angle_y``, eye
landmarks, ``pose_Tx ... pose_Rx, pose_Ry, pose_Rz``, face landmarks, model parameters,
``AU01_r ... AU45_r`` and ``AU01_c ... AU45_c``; names after the first are written with a
leading space (", "), values the same way. ``timestamp`` is in seconds, ``success`` is 0/1,
angles are radians, AU intensities run 0-5.

The mapping is :func:`openface_mapping`; docs/capture.md tabulates it with the source of each
sign: OpenFace's camera frame is x right, y down, z away from the camera, so FAP 48 (head
pitch, + down) = ``+pose_Rx``, FAP 49 (yaw, + to the face's left) = ``-pose_Ry``, FAP 50 (roll)
= ``-pose_Rz``; gaze FAP 23-26 = ``+gaze_angle_x`` / ``+gaze_angle_y``; eyebrows FAP 31-36 from
AU01 (inner raiser), AU02 (outer raiser) and AU04 (lowerer); eyelids FAP 19-22 from AU45
(blink); jaw FAP 3 from AU26.

Angles become AU (1e-5 rad). The AU scales are a calibration, not a measurement: 25 ENS units
per AU intensity puts a typical raise (intensity 1.5-2) at the 38-50 units the thesis' raises
imply (docs/stimuli.md); an AU45 of 3 is taken as fully closed. Every scale is a parameter
(:func:`openface_mapping`). Frames with ``success = 0`` or ``confidence`` under
:data:`MIN_CONFIDENCE` are gaps, filled linearly up to
:data:`~app.stimuli.capture.timeline.MAX_GAP_S`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.errors import InputError
from app.stimuli.capture.csvfile import read_numeric_csv
from app.stimuli.capture.mapping import FapMapping
from app.stimuli.capture.timeline import MAX_GAP_S, to_track
from app.stimuli.track import MotionTrack

REQUIRED = ("frame", "timestamp", "confidence", "success")
#: Frames whose landmark confidence is lower are treated as lost.
MIN_CONFIDENCE = 0.75


def openface_mapping(
    brow: float = 25.0, jaw: float = 120.0, blink_closed: float = 3.0
) -> FapMapping:
    """The table of the module docstring with its scales (FAPU per AU intensity)."""
    inner = {"AU01_r": brow, "AU04_r": -brow}
    middle = {"AU01_r": brow / 2, "AU02_r": brow / 2, "AU04_r": -brow}
    outer = {"AU02_r": brow, "AU04_r": -brow}
    return FapMapping(
        angles={
            48: ("pose_Rx", 1.0),
            49: ("pose_Ry", -1.0),
            50: ("pose_Rz", -1.0),
            23: ("gaze_angle_x", 1.0),
            24: ("gaze_angle_x", 1.0),
            25: ("gaze_angle_y", 1.0),
            26: ("gaze_angle_y", 1.0),
        },
        sums={
            31: inner,
            32: inner,
            33: middle,
            34: middle,
            35: outer,
            36: outer,
            3: {"AU26_r": jaw},
        },
        lids={c: ("AU45_r", blink_closed) for c in (19, 20, 21, 22)},
    )


OPENFACE_MAP = openface_mapping()


def _header_problem(header: list[str]) -> str | None:
    missing = [h for h in REQUIRED if h not in header]
    if missing:
        return f"not an OpenFace FeatureExtraction CSV: no {', '.join(missing)} column"
    return None


def is_openface(header: list[str]) -> bool:
    """True for an OpenFace FeatureExtraction header (names stripped of spaces)."""
    return header[:2] == ["frame", "face_id"] and "success" in header


def read_openface(
    path: str | Path,
    fps: float = 30.0,
    *,
    min_confidence: float = MIN_CONFIDENCE,
    max_gap_s: float = MAX_GAP_S,
    mapping: FapMapping = OPENFACE_MAP,
) -> MotionTrack:
    """Read an OpenFace 2.0 CSV as a FAP track at ``fps`` (see the module docstring).

    The track's ``metadata["capture"]`` reports dropped frames, filled gaps and the FAPs
    left out for want of columns (``missing``). Bad input: one :class:`InputError` naming the
    file, row and column.
    """
    table = read_numeric_csv(path, check_header=_header_problem)
    header, data, rows = table.header, table.values, table.lines
    col = {name: i for i, name in enumerate(header)}

    def column(name: str) -> np.ndarray:
        return data[:, col[name]]

    faps = mapping.apply(column, set(col))
    if not faps:
        raise InputError(
            "no pose_R*, gaze_angle_* or AU*_r columns to import (run "
            "FeatureExtraction with -pose -gaze -aus)",
            path=path,
        )
    valid = (column("success") > 0.5) & (column("confidence") >= min_confidence)
    track, report = to_track(
        column("timestamp"),
        faps,
        valid,
        fps=fps,
        path=str(path),
        max_gap_s=max_gap_s,
        rows=rows,
        name=Path(path).stem,
        source=f"OpenFace 2.0 CSV {Path(path).name}",
    )
    report["missing"] = mapping.needs(set(col))
    return mapping.limit(track).replace(metadata={**track.metadata, "capture": report})
