"""OpenFace 2.0 FeatureExtraction CSV -> FAP track (head, gaze, eyebrows, eyelids, jaw).

The file (``RecorderCSV`` in OpenFace 2.x) starts ``frame, face_id, timestamp, confidence,
success`` and then, as the tracker was asked, ``gaze_0_x ... gaze_angle_x, gaze_angle_y``, eye
landmarks, ``pose_Tx ... pose_Rx, pose_Ry, pose_Rz``, face landmarks, model parameters,
``AU01_r ... AU45_r`` and ``AU01_c ... AU45_c``; names after the first are written with a
leading space (", "), values the same way. ``timestamp`` is in seconds, ``success`` is 0/1,
angles are radians, AU intensities run 0-5.

The mapping is :func:`openface_mapping` for the AUs and :mod:`~app.stimuli.capture.headframe`
for the head and the eyes; docs/reference/capture.md tabulates it with the source of each sign.

* Head, FAP 48-50: OpenFace's ``pose_R*`` are the head's rotation relative to the *camera*
  (its wiki, "Output Format": "Rotation is in radians around X,Y,Z axes with the convention
  R = Rx * Ry * Rz ... The rotation is in world coordinates with camera being the origin"),
  so a take keeps the camera's angle. The camera frame is x right, y down, z away from the
  camera; the face frame (x the face's left, y up, z out of the face) is the camera frame
  turned half a turn about x, ``F = diag(1, -1, -1)``, so ``R_face = F R F``. Each frame is
  then taken relative to the take's neutral (:class:`~app.stimuli.capture.headframe.Neutral`:
  the median pose by default). Small angles reduce to the old table: FAP 48 = ``+pose_Rx``,
  49 = ``-pose_Ry``, 50 = ``-pose_Rz``.
* Eyes, FAP 23-26: OpenFace's gaze is in the camera's frame too ("eye gaze direction vector in
  world coordinates"; ``gaze_angle_x/y = atan2(g.x, -g.z), atan2(g.y, -g.z)`` of the mean of
  both eyes' vectors, ``GazeAnalysis::GetGazeAngle``). Stored as eye-in-head rotation, that
  turned the eyes with the head twice. The per-eye vectors ``gaze_1`` (the person's left eye,
  rightmost in the image) and ``gaze_0`` (right eye) are rotated into the frame of the head
  relative to the neutral, ``d = R_rel^T F g`` (the camera stands for the viewer: see
  :mod:`~app.stimuli.capture.headframe`); a file without usable vectors (all zero) uses the
  mean direction ``(tan x, tan y, -1)`` of the angles for both eyes.
* Eyebrows FAP 31-36 from AU01 (inner raiser), AU02 (outer raiser) and AU04 (lowerer);
  eyelids FAP 19-22 from AU45 (blink); jaw FAP 3 from AU26.

Angles become AU (1e-5 rad). The AU scales are a calibration, not a measurement: 25 ENS units
per AU intensity puts a typical raise (intensity 1.5-2) at the 38-50 units the thesis' raises
imply (docs/reference/stimuli.md); an AU45 of 3 is taken as fully closed. Every scale is a parameter
(:func:`openface_mapping`). Frames with ``success = 0`` or ``confidence`` under
:data:`MIN_CONFIDENCE` are gaps, filled linearly up to
:data:`~app.stimuli.capture.timeline.MAX_GAP_S`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.capture.csvfile import read_numeric_csv
from app.stimuli.capture.headframe import (
    Neutral,
    eye_in_head,
    head_angles,
    relative_to_neutral,
    rotations,
)
from app.stimuli.capture.mapping import FapMapping
from app.stimuli.capture.timeline import MAX_GAP_S, to_track
from app.stimuli.fap import AU_RADIANS
from app.stimuli.track import MotionTrack

REQUIRED = ("frame", "timestamp", "confidence", "success")
#: Frames whose landmark confidence is lower are treated as lost.
MIN_CONFIDENCE = 0.75
#: What ``gaze_neutral`` takes: the take's median gaze out of the eyes, or nothing.
GAZE_NEUTRALS = ("none", "median")
#: A take's median gaze this far from the camera (degrees) is said in the import summary.
GAZE_OFFSET_SAID_DEG = 5.0
POSE = ("pose_Rx", "pose_Ry", "pose_Rz")
GAZE_ANGLES = ("gaze_angle_x", "gaze_angle_y")
#: The person's left eye (FAP 23, 25) is OpenFace's eye 1, the rightmost in the image.
GAZE_VECTORS = {
    "left": ("gaze_1_x", "gaze_1_y", "gaze_1_z"),
    "right": ("gaze_0_x", "gaze_0_y", "gaze_0_z"),
}
#: The camera frame (x right, y down, z away) in the face frame (x left, y up, z out).
CAMERA_TO_FACE = np.diag([1.0, -1.0, -1.0])


def openface_mapping(
    brow: float = 25.0, jaw: float = 120.0, blink_closed: float = 3.0
) -> FapMapping:
    """The AU table of the module docstring with its scales (FAPU per AU intensity)."""
    inner = {"AU01_r": brow, "AU04_r": -brow}
    middle = {"AU01_r": brow / 2, "AU02_r": brow / 2, "AU04_r": -brow}
    outer = {"AU02_r": brow, "AU04_r": -brow}
    return FapMapping(
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


def head_rotations(pose: np.ndarray) -> np.ndarray:
    """(n, 3, 3) face-frame head rotations ``F (Rx Ry Rz) F`` of OpenFace's ``pose_R*``
    (n, 3), radians; non-finite rows give NaN matrices."""
    ok = np.all(np.isfinite(pose), axis=1)
    rot = rotations("XYZ", np.where(ok[:, None], pose, 0.0))
    rot = CAMERA_TO_FACE @ rot @ CAMERA_TO_FACE
    rot[~ok] = np.nan
    return rot


def _gaze_directions(column, names: set[str], valid: np.ndarray) -> dict[str, np.ndarray] | None:
    """Per-eye gaze directions in the face frame (n, 3), from the vectors when they are unit
    vectors in the valid frames, else from the mean angles; None without gaze columns."""
    if all(c in names for cols in GAZE_VECTORS.values() for c in cols):
        vec = {e: np.column_stack([column(c) for c in cols]) for e, cols in GAZE_VECTORS.items()}
        norms = np.concatenate([np.linalg.norm(v[valid], axis=1) for v in vec.values()])
        if norms.size and np.median(norms) > 0.9:
            return {eye: v @ CAMERA_TO_FACE for eye, v in vec.items()}
    if all(c in names for c in GAZE_ANGLES):
        with np.errstate(invalid="ignore", over="ignore"):
            tx, ty = np.tan(column("gaze_angle_x")), np.tan(column("gaze_angle_y"))
        mean = np.column_stack([tx, ty, -np.ones(len(valid))])
        face = mean @ CAMERA_TO_FACE
        return {"left": face, "right": face}
    return None


def _head_and_eyes(
    column: Callable[[str], np.ndarray],
    names: set[str],
    valid: np.ndarray,
    neutral: Neutral,
    path: str,
    gaze_neutral: str = "none",
) -> tuple[dict[int, np.ndarray], dict[str, Any]]:
    """FAP 48-50 relative to the neutral and FAP 23-26 in the head's frame, and their report."""
    faps: dict[int, np.ndarray] = {}
    report_extra: dict[str, Any] = {}
    head = None  # the head relative to the neutral: the eyes are turned by it
    if all(c in names for c in POSE):
        measured = head_rotations(np.column_stack([column(c) for c in POSE]))
        relative, base = relative_to_neutral(measured, column("timestamp"), valid, neutral, path)
        bad = ~np.all(np.isfinite(relative.reshape(len(relative), 9)), axis=1)
        angles = head_angles(np.where(bad[:, None, None], np.eye(3), relative)) / AU_RADIANS
        angles[bad] = np.nan
        faps.update({48: angles[:, 0], 49: angles[:, 1], 50: angles[:, 2]})
        head = relative
        report_extra["neutral"] = {
            "method": neutral.method,
            "described": neutral.describe(),
            "pitch_deg": round(float(np.degrees(base[0])), 2),
            "yaw_deg": round(float(np.degrees(base[1])), 2),
            "roll_deg": round(float(np.degrees(base[2])), 2),
        }
    gaze = _gaze_directions(column, names, valid)
    if gaze is not None:
        still = np.broadcast_to(np.eye(3), (len(valid), 3, 3))
        seen_from = still if head is None else np.where(np.isfinite(head), head, still)
        for eye, (yaw_fap, pitch_fap) in (("left", (23, 25)), ("right", (24, 26))):
            eye_angles = eye_in_head(seen_from, gaze[eye]) / AU_RADIANS
            faps[yaw_fap], faps[pitch_fap] = eye_angles[:, 0], eye_angles[:, 1]
        report_extra["gaze"] = (
            "turned from the camera's frame into the head's"
            if head is not None
            else "in the camera's frame (no pose_R* columns to turn it into the head's)"
        )
        report_extra.update(_gaze_offset(faps, valid, gaze_neutral))
    return faps, report_extra


def _gaze_offset(
    faps: dict[int, np.ndarray], valid: np.ndarray, gaze_neutral: str
) -> dict[str, Any]:
    """The take's median gaze (both eyes' mean, degrees), reported; with ``gaze_neutral``
    ``"median"`` taken out of FAP 23-26 in place. A take filmed by a camera below the eyes'
    line looks down by its angle throughout (22 degrees in a real OpenFace take): a face that
    looks at the floor for a whole study."""
    offsets = {}
    for kind, pair in (("yaw", (23, 24)), ("pitch", (25, 26))):
        both = np.column_stack([faps[f] for f in pair])[valid]
        finite = both[np.isfinite(both).all(axis=1)]
        median = np.median(finite, axis=0) if len(finite) else np.zeros(2)
        offsets[kind] = float(np.degrees(median.mean() * AU_RADIANS))
        if gaze_neutral == "median":
            for fap, m in zip(pair, median, strict=True):
                faps[fap] = faps[fap] - m
    report: dict[str, Any] = {
        "gaze_offset": {
            "method": gaze_neutral,
            "yaw_deg": round(offsets["yaw"], 2),  # + the face's left
            "pitch_deg": round(offsets["pitch"], 2),  # + down
        }
    }
    big = max(abs(offsets["yaw"]), abs(offsets["pitch"])) >= GAZE_OFFSET_SAID_DEG
    if big:
        up_down = "down" if offsets["pitch"] > 0 else "up"
        side = "left" if offsets["yaw"] > 0 else "right"
        where = (
            f"{abs(offsets['pitch']):.1f} deg {up_down} and "
            f"{abs(offsets['yaw']):.1f} deg to the face's {side}"
        )
        report["warnings"] = [
            f"the eyes look {where} over the take (median)"
            + (
                ", taken out (--gaze-neutral median)"
                if gaze_neutral == "median"
                else "; a camera off the eyes' line? --gaze-neutral median takes it out"
            )
        ]
    return report


def read_openface(
    path: str | Path,
    fps: float = 30.0,
    *,
    min_confidence: float = MIN_CONFIDENCE,
    max_gap_s: float = MAX_GAP_S,
    mapping: FapMapping = OPENFACE_MAP,
    neutral: Neutral | None = None,
    gaze_neutral: str = "none",
) -> MotionTrack:
    """Read an OpenFace 2.0 CSV as a FAP track at ``fps`` (see the module docstring).

    ``neutral`` says which pose the head is measured from (default: the take's median pose);
    ``gaze_neutral`` ``"median"`` takes the take's median gaze out of the eyes (default
    ``"none"``: kept, and reported as ``gaze_offset`` with a warning from 5 degrees).
    The track's ``metadata["capture"]`` reports dropped frames, filled gaps, the neutral
    (``neutral``: method and its pitch, yaw, roll in degrees from the camera's axis), the gaze
    source and the FAPs left out for want of columns (``missing``). Bad input: one
    :class:`InputError` naming the file, row and column.
    """
    neutral = neutral or Neutral()
    if gaze_neutral not in GAZE_NEUTRALS:
        raise InputError(
            f"expected one of {', '.join(GAZE_NEUTRALS)}, got {gaze_neutral!r}",
            field="--gaze-neutral",
        )
    table = read_numeric_csv(path, check_header=_header_problem)
    header, data, rows = table.header, table.values, table.lines
    col = {name: i for i, name in enumerate(header)}
    names = set(col)

    def column(name: str) -> np.ndarray:
        return data[:, col[name]]

    valid = (column("success") > 0.5) & (column("confidence") >= min_confidence)
    with np.errstate(over="ignore", invalid="ignore"):  # overflowing values: lost samples
        faps, report_extra = _head_and_eyes(column, names, valid, neutral, str(path), gaze_neutral)
    faps.update(mapping.apply(column, names))
    if not faps:
        raise InputError(
            "no pose_R*, gaze_* or AU*_r columns to import (run "
            "FeatureExtraction with -pose -gaze -aus)",
            path=path,
        )
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
    missing = mapping.needs(names)
    for cols, given in ((POSE, [48, 49, 50]), (GAZE_ANGLES, [23, 24, 25, 26])):
        if given[0] not in faps:
            missing.update({c: given for c in cols if c not in names})
    warnings = report_extra.pop("warnings", [])
    report.update(report_extra, missing=missing)
    report["warnings"] = [*report.get("warnings", []), *warnings]
    return mapping.limit(track).replace(metadata={**track.metadata, "capture": report})
