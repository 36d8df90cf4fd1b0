"""ARKit blendshape CSV, as Live Link Face writes it, to and from FAP tracks.

Layout (one take exported from Epic's Live Link Face app): a header ``Timecode,
BlendShapeCount,`` then the 52 ARKit blendshapes in the app's order (:data:`BLENDSHAPES`,
``EyeBlinkLeft`` ... ``TongueOut``, coefficients 0-1) and 9 rotations ``HeadYaw, HeadPitch,
HeadRoll, LeftEyeYaw, LeftEyePitch, LeftEyeRoll, RightEyeYaw, RightEyePitch, RightEyeRoll``
(radians, the values the app also streams); ``BlendShapeCount`` is 61. ``Timecode`` is
``HH:MM:SS:FF.sss``: frame ``FF`` of the app's frame rate (60 by default, 30 on request),
read by :mod:`app.stimuli.capture.timecode`. Columns are found by name, case-insensitively,
so files from other ARKit recorders with the same names read too. Columns that hold one value
in every frame are reported; FAPs whose columns are all 0 (a take recorded with head rotation
off) are left out with a warning rather than imported as a still head
(:meth:`FapMapping.constant`).

The mapping is :func:`arkit_mapping`; docs/reference/capture.md tabulates it with the source of each
sign: ARKit's face frame is x to the face's left, y up, z out of the face, so FAP 48-50 =
``+HeadPitch``, ``+HeadYaw``, ``+HeadRoll``; gaze FAP 23-26 from the eye rotations; eyebrows
FAP 31-36 from ``BrowInnerUp``, ``BrowOuterUp*`` and ``BrowDown*`` (100 units per 1.0);
eyelids FAP 19-22 from ``EyeBlink*``; jaw FAP 3 = ``800 * JawOpen``.

"Left" is the face's own left in both ARKit and MPEG-4. The signs follow from ARKit's
documented face coordinate frame; the app's exported angles have not been checked here
against a recorded nod and turn, so check once with your own take (a nod down must give a
positive FAP 48 in ``facepair capture import``) and flip an axis with ``flip``. The
blendshape scales are a calibration (a brow raise of 0.4 gives the thesis' 40 units).

:func:`write_arkit_csv` writes the inverse of this table (the eyebrows' middle values, which
it cannot carry, are dropped), so facepair's tracks play on ARKit rigs and MetaHumans.
"""

from __future__ import annotations

import csv
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from app.errors import InputError
from app.stimuli.capture.csvfile import read_numeric_csv
from app.stimuli.capture.mapping import IRISD_CLOSED, LID_SHARE, FapMapping, columns_to_track
from app.stimuli.capture.timecode import TIMECODE, frame_times, timecode_problem
from app.stimuli.capture.timeline import MAX_GAP_S
from app.stimuli.fap import AU_RADIANS
from app.stimuli.track import MotionTrack

#: The 52 ARKit blendshapes in Live Link Face's column order.
BLENDSHAPES: tuple[str, ...] = (
    "EyeBlinkLeft",
    "EyeLookDownLeft",
    "EyeLookInLeft",
    "EyeLookOutLeft",
    "EyeLookUpLeft",
    "EyeSquintLeft",
    "EyeWideLeft",
    "EyeBlinkRight",
    "EyeLookDownRight",
    "EyeLookInRight",
    "EyeLookOutRight",
    "EyeLookUpRight",
    "EyeSquintRight",
    "EyeWideRight",
    "JawForward",
    "JawRight",
    "JawLeft",
    "JawOpen",
    "MouthClose",
    "MouthFunnel",
    "MouthPucker",
    "MouthRight",
    "MouthLeft",
    "MouthSmileLeft",
    "MouthSmileRight",
    "MouthFrownLeft",
    "MouthFrownRight",
    "MouthDimpleLeft",
    "MouthDimpleRight",
    "MouthStretchLeft",
    "MouthStretchRight",
    "MouthRollLower",
    "MouthRollUpper",
    "MouthShrugLower",
    "MouthShrugUpper",
    "MouthPressLeft",
    "MouthPressRight",
    "MouthLowerDownLeft",
    "MouthLowerDownRight",
    "MouthUpperUpLeft",
    "MouthUpperUpRight",
    "BrowDownLeft",
    "BrowDownRight",
    "BrowInnerUp",
    "BrowOuterUpLeft",
    "BrowOuterUpRight",
    "CheekPuff",
    "CheekSquintLeft",
    "CheekSquintRight",
    "NoseSneerLeft",
    "NoseSneerRight",
    "TongueOut",
)
ROTATIONS: tuple[str, ...] = (
    "HeadYaw",
    "HeadPitch",
    "HeadRoll",
    "LeftEyeYaw",
    "LeftEyePitch",
    "LeftEyeRoll",
    "RightEyeYaw",
    "RightEyePitch",
    "RightEyeRoll",
)
HEADER: tuple[str, ...] = ("Timecode", "BlendShapeCount", *BLENDSHAPES, *ROTATIONS)
APP_RATES = (24.0, 25.0, 30.0, 48.0, 50.0, 60.0)
BROW, JAW = 100.0, 800.0
#: The brow coefficients taken relative to the take's rest (``brow_neutral``).
BROW_SHAPES = (
    "BrowDownLeft",
    "BrowDownRight",
    "BrowInnerUp",
    "BrowOuterUpLeft",
    "BrowOuterUpRight",
)
BROW_NEUTRALS = ("median", "none")
#: A brow rest this far from ARKit's 0 (of 1) is said in the import summary.
BROW_REST_SAID = 0.02


def arkit_mapping(brow: float = BROW, jaw: float = JAW, flip: Iterable[str] = ()) -> FapMapping:
    """The table of the module docstring; ``flip`` names rotation columns whose sign to turn
    (e.g. ``("HeadPitch",)``)."""
    flipped = {name.lower() for name in flip}

    def angle(name: str) -> tuple[str, float]:
        return name, -1.0 if name.lower() in flipped else 1.0

    def brows(side: str) -> dict[int, dict[str, float]]:
        down, outer = f"BrowDown{side}", f"BrowOuterUp{side}"
        i, m, o = (31, 33, 35) if side == "Left" else (32, 34, 36)
        return {
            i: {"BrowInnerUp": brow, down: -brow},
            m: {"BrowInnerUp": brow / 2, outer: brow / 2, down: -brow},
            o: {outer: brow, down: -brow},
        }

    return FapMapping(
        angles={
            48: angle("HeadPitch"),
            49: angle("HeadYaw"),
            50: angle("HeadRoll"),
            23: angle("LeftEyeYaw"),
            24: angle("RightEyeYaw"),
            25: angle("LeftEyePitch"),
            26: angle("RightEyePitch"),
        },
        sums={**brows("Left"), **brows("Right"), 3: {"JawOpen": jaw}},
        lids={
            19: ("EyeBlinkLeft", 1.0),
            21: ("EyeBlinkLeft", 1.0),
            20: ("EyeBlinkRight", 1.0),
            22: ("EyeBlinkRight", 1.0),
        },
    )


ARKIT_MAP = arkit_mapping()


def is_arkit(header: list[str]) -> bool:
    """True for a Live Link Face header (``Timecode, BlendShapeCount, ...``)."""
    return [h.lower() for h in header[:2]] == ["timecode", "blendshapecount"]


def read_arkit_csv(
    path: str | Path,
    fps: float = 30.0,
    *,
    app_fps: float | None = None,
    max_gap_s: float = MAX_GAP_S,
    mapping: FapMapping = ARKIT_MAP,
    brow_neutral: str = "median",
) -> MotionTrack:
    """A Live Link Face CSV as a FAP track at ``fps`` (timecode to time, then resampled).

    ``app_fps`` is the app's frame rate behind the timecodes; by default the smallest of
    24/25/30/48/50/60 above every frame number in the file (60 for a take under a second).
    ``brow_neutral``: ``"median"`` takes each brow coefficient relative to its median over
    the take (the speaker's rest: a take's brows are rarely at ARKit's 0), ``"none"`` keeps
    them as recorded; the summary reports the rest.
    """
    if brow_neutral not in BROW_NEUTRALS:
        raise InputError(
            f"expected one of {', '.join(BROW_NEUTRALS)}, got {brow_neutral!r}",
            field="--brow-neutral",
        )
    p = Path(path)
    table = read_numeric_csv(
        p, check_header=_header_problem, text_columns={"Timecode": timecode_problem}
    )
    header, data, rows = table.header, table.values, table.lines
    stamps = table.text[header[0]]
    names = {h.lower(): i for i, h in enumerate(header)}
    if app_fps is None:
        top = max(int(TIMECODE.match(s).group(4)) for s in stamps)  # type: ignore[union-attr]
        app_fps = next((r for r in APP_RATES if r > top), 60.0)
    times, fraction = frame_times(stamps, app_fps)

    rest = {}
    if brow_neutral == "median":
        for name in BROW_SHAPES:
            if name.lower() in names:
                values = data[:, names[name.lower()]]
                finite = values[np.isfinite(values)]
                rest[name] = float(np.median(finite)) if len(finite) else 0.0

    def recorded(name: str) -> np.ndarray:
        return data[:, names[name.lower()]]

    def column(name: str) -> np.ndarray:
        return recorded(name) - rest.get(name, 0.0)

    available = {h for h in (*BLENDSHAPES, *ROTATIONS) if h.lower() in names}
    track = columns_to_track(
        mapping,
        times,
        column,
        available,
        fps=fps,
        path=str(p),
        max_gap_s=max_gap_s,
        rows=rows,
        name=p.stem,
        source=f"ARKit blendshape CSV {p.name}",
        recorded=recorded,
    )
    report = track.metadata["capture"]
    report.update(
        app_fps=app_fps,
        timecode="frame numbers and their sub-frame fractions" if fraction else "frame numbers",
        brow_rest={k: round(v, 4) for k, v in rest.items()},
    )
    if any(abs(v) >= BROW_REST_SAID for v in rest.values()):
        said = ", ".join(f"{k} {v:.2f}" for k, v in rest.items() if abs(v) >= BROW_REST_SAID)
        report.setdefault("warnings", []).append(
            f"brows relative to the take's rest (median {said}); --brow-neutral none keeps "
            "them as recorded"
        )
    return track


def _header_problem(header: list[str]) -> str | None:
    if is_arkit(header):
        return None
    return "not a Live Link Face CSV: the header must start 'Timecode,BlendShapeCount'"


def write_arkit_csv(track: MotionTrack, path: str | Path, *, app_fps: float | None = None) -> None:
    """Write ``track`` in Live Link Face's layout: the inverse of :func:`arkit_mapping`.

    Timecodes count frames of ``app_fps`` (default: the track's rate). Blendshapes are
    clipped to 0-1; FAPs the table does not cover are not written.
    """
    rate = float(app_fps or track.fps)
    n = track.n_frames
    weights = arkit_weights(track.dense())
    cols = {
        name: np.clip(weights[name], 0.0, 1.0) if name in BLENDSHAPES else weights[name]
        for name in (*BLENDSHAPES, *ROTATIONS)
    }
    with Path(path).open("w", newline="", encoding="utf-8") as f:
        out = csv.writer(f, lineterminator="\n")
        out.writerow(HEADER)
        for k in range(n):
            t = k / track.fps
            frames = t * rate
            whole = int(np.floor(frames + 1e-9))
            secs, ff = divmod(whole, int(round(rate)))
            h, rem = divmod(secs, 3600)
            mi, s = divmod(rem, 60)
            stamp = f"{h:02d}:{mi:02d}:{s:02d}:{ff:02d}.{round((frames - whole) * 1000):03d}"
            out.writerow(
                [
                    stamp,
                    len(BLENDSHAPES) + len(ROTATIONS),
                    *(f"{cols[name][k]:.6f}" for name in (*BLENDSHAPES, *ROTATIONS)),
                ]
            )


def arkit_weights(faps: np.ndarray) -> dict[str, np.ndarray]:
    """Per-frame ARKit blendshape weights and rotations (radians) of FAP frames: the inverse
    of :func:`arkit_mapping`, shared by :func:`write_arkit_csv` and the renderer's avatars.

    ``faps``: (n, 68) FAP values (column k is FAP k+1, as :meth:`MotionTrack.dense` gives) or
    one frame of 68. Returns every name of :data:`BLENDSHAPES` and :data:`ROTATIONS`, each an
    array of n values (a 0-d array for one frame); blendshapes the table does not drive are 0.
    The weights are not clipped: a brow raised past 100 units gives more than 1.

    >>> faps = np.zeros(68); faps[3 - 1] = 400.0
    >>> float(arkit_weights(faps)["JawOpen"])
    0.5
    """
    f = np.asarray(faps, dtype=np.float64)

    def g(fap: int) -> np.ndarray:
        return f[..., fap - 1]

    zero = np.zeros(f.shape[:-1])
    cols: dict[str, np.ndarray] = {name: zero for name in (*BLENDSHAPES, *ROTATIONS)}
    for fap, name in (
        (48, "HeadPitch"),
        (49, "HeadYaw"),
        (50, "HeadRoll"),
        (23, "LeftEyeYaw"),
        (24, "RightEyeYaw"),
        (25, "LeftEyePitch"),
        (26, "RightEyePitch"),
    ):
        cols[name] = g(fap) * AU_RADIANS
    inner_up = []
    for side, i, o in (("Left", 31, 35), ("Right", 32, 36)):
        down = np.clip(-np.minimum(g(i), g(o)), 0, None) / BROW
        cols[f"BrowDown{side}"] = down
        cols[f"BrowOuterUp{side}"] = g(o) / BROW + down
        inner_up.append(g(i) / BROW + down)
    cols["BrowInnerUp"] = (inner_up[0] + inner_up[1]) / 2  # one shape for both sides
    cols["EyeBlinkLeft"] = g(19) / (LID_SHARE[19] * IRISD_CLOSED)
    cols["EyeBlinkRight"] = g(20) / (LID_SHARE[20] * IRISD_CLOSED)
    cols["JawOpen"] = g(3) / JAW
    return cols
