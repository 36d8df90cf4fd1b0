"""ARKit-52 weight tracks written by speech-driven tools: Audio2Face's CSV and JSON, OpenFaceFX's.

A team that brings its own audio-driven system usually has it write ARKit blendshape weights,
in one of the layouts NVIDIA's Audio2Face made common. Both map through the Live Link Face
table (:func:`~app.stimuli.capture.arkit.arkit_mapping`): blendshape names are matched to
ARKit's 52 case-insensitively (``jawOpen``, ``JawOpen``), names outside them are reported and
not used. Neither layout carries head or eye rotation; the summary says so (``missing``).

* **Audio2Face-3D CSV** (``animation_frames.csv``), as the microservice's sample client writes
  it (NVIDIA/Audio2Face-3D-Samples, ``scripts/audio2face_3d_api_client/a2f_3d/client/
  service.py``): each frame ``{"timeCode": t, "blendShapes": {name: weight}}`` flattened by
  ``pandas.json_normalize`` and written with ``to_csv``, so the header is ``,timeCode,
  blendShapes.EyeBlinkLeft, ...`` (the first, unnamed column is pandas' row index) and
  ``timeCode`` is in seconds.
* **Audio2Face JSON** (the app's "Export blendshape weights as .json", and OpenFaceFX's
  ``export_a2f.write_a2f``): ``{"exportFps": 30, "numPoses": P, "numFrames": N,
  "facsNames": [P names], "weightMat": [N rows of P weights], ...}``; frame k is at
  ``k / exportFps``. Other keys (``trackPath``, ``joints``, ``rotations``) are ignored.
* **OpenFaceFX tracks** (OpenFaceFX/OpenFaceFX, ``src/openfacefx/io_export.py``): the JSON
  ``{"format": "openfacefx.track", "version": 1, "fps": F, "channels": [{"name": n, "keys":
  [[t, v], ...]}]}`` and the CSV ``time,channel,value`` (one row per key). The keys are a
  Ramer-Douglas-Peucker thinning of the dense curve (``curves.reduce_to_track``), so the curve
  is the straight line between keys; a channel that never fires is not written (0). They are
  sampled at the track's ``fps`` (the CSV has none: the requested rate). Channels are Oculus
  visemes unless the track was retargeted to ARKit (``--retarget arkit``); visemes are not
  ARKit weights and are named as not imported.

Bad input is one :class:`~app.errors.InputError` naming the file and the line (CSV) or the
``weightMat`` row (JSON).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from app.errors import InputError
from app.stimuli.capture.arkit import ARKIT_MAP, BLENDSHAPES
from app.stimuli.capture.csvfile import read_numeric_csv
from app.stimuli.capture.mapping import FapMapping, columns_to_track
from app.stimuli.capture.timeline import MAX_GAP_S
from app.stimuli.track import MotionTrack

PREFIX = "blendshapes."
#: Largest JSON read, bytes: an hour of 52 weights at 60 fps is about 200 MB.
MAX_JSON_BYTES = 512 * 2**20
#: Latest key time of an OpenFaceFX track, seconds (4 hours; a bound on the grid).
MAX_KEY_TIME_S = 4 * 3600.0
_ARKIT = {name.lower(): name for name in BLENDSHAPES}


def is_a2f_csv(header: list[str]) -> bool:
    """True for Audio2Face-3D's ``animation_frames.csv`` header."""
    lower = [h.lower() for h in header]
    return "timecode" in lower and any(h.startswith(PREFIX) for h in lower)


def json_kind(path: str | Path) -> str | None:
    """``"a2f-json"``, ``"openfacefx-json"`` or ``None`` from the keys in the file's first
    64 KB (a large file is not parsed to sniff it)."""
    try:
        with Path(path).open("rb") as f:
            start = f.read(65536)
    except OSError:
        return None
    if b'"facsNames"' in start or b'"weightMat"' in start:
        return "a2f-json"
    if b'"openfacefx.track"' in start:
        return "openfacefx-json"
    return None


def _arkit_columns(names: list[str]) -> tuple[dict[str, str], list[str]]:
    """ARKit name -> the file's name for the names that are ARKit blendshapes, and the rest."""
    found: dict[str, str] = {}
    other = []
    for name in names:
        key = name.strip()
        if key.lower().startswith(PREFIX):
            key = key[len(PREFIX) :]
        arkit = _ARKIT.get(key.lower())
        if arkit and arkit not in found:
            found[arkit] = name
        else:
            other.append(name)
    return found, other


def _unused_line(other: list[str]) -> list[str]:
    if not other:
        return []
    shown = ", ".join(repr(o[:40]) for o in other[:6]) + (", ..." if len(other) > 6 else "")
    return [f"{len(other)} columns are not ARKit blendshapes and were not imported: {shown}"]


def read_a2f_csv(
    path: str | Path,
    fps: float = 30.0,
    *,
    max_gap_s: float = MAX_GAP_S,
    mapping: FapMapping = ARKIT_MAP,
) -> MotionTrack:
    """An Audio2Face-3D ``animation_frames.csv`` as a FAP track at ``fps``."""
    p = Path(path)

    def check(header: list[str]) -> str | None:
        if is_a2f_csv(header):
            return None
        return "not an Audio2Face-3D CSV: expected timeCode and blendShapes.* columns"

    table = read_numeric_csv(p, check_header=check)
    header, data = table.header, table.values
    index = {h: i for i, h in enumerate(header)}
    time_col = next(h for h in header if h.lower() == "timecode")
    weights = [h for h in header if h.lower().startswith(PREFIX)]
    found, other = _arkit_columns(weights)

    def column(name: str) -> np.ndarray:
        return data[:, index[found[name]]]

    track = columns_to_track(
        mapping,
        data[:, index[time_col]],
        column,
        set(found),
        fps=fps,
        path=str(p),
        max_gap_s=max_gap_s,
        rows=table.lines,
        name=p.stem,
        source=f"Audio2Face-3D CSV {p.name}",
    )
    track.metadata["capture"]["warnings"] += _unused_line(other)
    return track


def _json_problem(doc: object) -> str | None:
    if not isinstance(doc, dict):
        return f"expected a JSON object, got {type(doc).__name__}"
    names = doc.get("facsNames")
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        return "'facsNames' must be a non-empty list of blendshape names"
    mat = doc.get("weightMat")
    if not isinstance(mat, list) or not mat:
        return "'weightMat' must be a non-empty list of per-frame weight rows"
    for k, row in enumerate(mat):
        if not isinstance(row, list) or len(row) != len(names):
            got = len(row) if isinstance(row, list) else type(row).__name__
            return f"weightMat row {k}: {got} values for the {len(names)} facsNames"
        if not all(isinstance(w, (int, float)) and not isinstance(w, bool) for w in row):
            return f"weightMat row {k}: a weight is not a number"
    count = doc.get("numFrames")
    if count is not None and count != len(mat):
        return f"numFrames says {count!r}, weightMat has {len(mat)} rows"
    rate = doc.get("exportFps")
    if not isinstance(rate, (int, float)) or isinstance(rate, bool) or not 0 < rate < 1e4:
        return f"'exportFps' must be a frame rate in frames per second, got {rate!r}"
    return None


def read_a2f_json(
    path: str | Path,
    fps: float = 30.0,
    *,
    max_gap_s: float = MAX_GAP_S,
    mapping: FapMapping = ARKIT_MAP,
) -> MotionTrack:
    """An Audio2Face blendshape-weights JSON as a FAP track at ``fps``."""
    p = Path(path)
    doc = _load_json(p)
    problem = _json_problem(doc)
    if problem or not isinstance(doc, dict):
        raise InputError(f"not an Audio2Face weights JSON: {problem}", path=p)
    names: list[str] = doc["facsNames"]
    try:
        mat = np.array(doc["weightMat"], dtype=np.float64)
    except OverflowError:
        raise InputError("a weight in weightMat is beyond the range of numbers", path=p) from None
    found, other = _arkit_columns(names)
    at = {name: i for i, name in enumerate(names)}

    def column(name: str) -> np.ndarray:
        return mat[:, at[found[name]]]

    track = columns_to_track(
        mapping,
        np.arange(len(mat)) / float(doc["exportFps"]),
        column,
        set(found),
        fps=fps,
        path=str(p),
        max_gap_s=max_gap_s,
        name=p.stem,
        source=f"Audio2Face weights JSON {p.name}",
    )
    track.metadata["capture"]["warnings"] += _unused_line(other)
    return track


def is_openfacefx_csv(header: list[str]) -> bool:
    """True for OpenFaceFX's keyframe CSV header ``time,channel,value``."""
    return [h.lower() for h in header] == ["time", "channel", "value"]


def _keys_to_columns(
    keys: dict[str, list[tuple[float, float]]], fps: float
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Keyframes sampled on a grid at ``fps``, linearly between keys, held past the ends."""
    end = max((t for k in keys.values() for t, _ in k), default=0.0)
    times = np.arange(int(round(end * fps)) + 1) / fps
    columns = {}
    for name, k in keys.items():
        pairs = sorted(k)
        columns[name] = np.interp(times, [t for t, _ in pairs], [v for _, v in pairs])
    return times, columns


def _openfacefx_track(
    p: Path,
    keys: dict[str, list[tuple[float, float]]],
    fps: float,
    out_fps: float,
    max_gap_s: float,
    mapping: FapMapping,
) -> MotionTrack:
    found, other = _arkit_columns(list(keys))
    if not found:
        raise InputError(
            f"no ARKit channel among {len(keys)} ({', '.join(sorted(keys))[:60]}): an "
            "OpenFaceFX track of visemes; write it with --retarget arkit",
            path=p,
        )
    end = max(t for k in keys.values() for t, _ in k)
    if not 0 <= end <= MAX_KEY_TIME_S:
        raise InputError(f"keys run to {end:.3g} s; expected 0-{MAX_KEY_TIME_S:g} s", path=p)
    times, columns = _keys_to_columns({a: keys[n] for a, n in found.items()}, fps)
    if len(times) < 2:
        raise InputError("every key is at 0 s: no motion to import", path=p)
    silent = np.zeros(len(times))  # OpenFaceFX writes no channel that never fires

    track = columns_to_track(
        mapping,
        times,
        lambda name: columns.get(name, silent),
        set(BLENDSHAPES),
        fps=out_fps,
        path=str(p),
        max_gap_s=max_gap_s,
        name=p.stem,
        source=f"OpenFaceFX track {p.name}",
    )
    track.metadata["capture"]["warnings"] += _unused_line(other)
    return track


def read_openfacefx_json(
    path: str | Path,
    fps: float = 30.0,
    *,
    max_gap_s: float = MAX_GAP_S,
    mapping: FapMapping = ARKIT_MAP,
) -> MotionTrack:
    """An OpenFaceFX ``.track.json`` (ARKit channels) as a FAP track at ``fps``."""
    p = Path(path)
    doc = _load_json(p)
    if not isinstance(doc, dict) or doc.get("format") != "openfacefx.track":
        raise InputError("not an OpenFaceFX track: no 'format': 'openfacefx.track'", path=p)
    rate = doc.get("fps")
    if not isinstance(rate, (int, float)) or isinstance(rate, bool) or not 0 < rate < 1e4:
        raise InputError(f"'fps' must be a frame rate, got {rate!r}", path=p)
    channels = doc.get("channels")
    if not isinstance(channels, list):
        raise InputError("'channels' must be a list of {name, keys}", path=p)
    keys: dict[str, list[tuple[float, float]]] = {}
    for i, channel in enumerate(channels):
        pairs = channel.get("keys") if isinstance(channel, dict) else None
        name = channel.get("name") if isinstance(channel, dict) else None
        if (
            not isinstance(name, str)
            or name in keys
            or not isinstance(pairs, list)
            or not pairs
            or not all(
                isinstance(k, list) and len(k) == 2 and all(_finite(x) for x in k) for k in pairs
            )
        ):
            raise InputError(
                f"channel {i}: expected a new 'name' and 'keys' of [time, value] numbers", path=p
            )
        keys[name] = [(float(t), float(v)) for t, v in pairs]
    if not keys:
        raise InputError("no channels", path=p)
    return _openfacefx_track(p, keys, float(rate), fps, max_gap_s, mapping)


def read_openfacefx_csv(
    path: str | Path,
    fps: float = 30.0,
    *,
    max_gap_s: float = MAX_GAP_S,
    mapping: FapMapping = ARKIT_MAP,
) -> MotionTrack:
    """An OpenFaceFX keyframe CSV (``time,channel,value``) as a FAP track at ``fps``."""
    p = Path(path)

    def check(header: list[str]) -> str | None:
        return None if is_openfacefx_csv(header) else "expected the header time,channel,value"

    table = read_numeric_csv(p, check_header=check, text_columns={"channel": lambda s: None})
    names = table.text[table.header[1]]
    keys: dict[str, list[tuple[float, float]]] = {}
    for (t, _, v), name, line in zip(table.values, names, table.lines, strict=True):
        if not (np.isfinite(t) and np.isfinite(v)):
            raise InputError("time and value must be finite numbers", path=p, line=int(line))
        keys.setdefault(name, []).append((float(t), float(v)))
    return _openfacefx_track(p, keys, fps, fps, max_gap_s, mapping)


def _finite(x: object) -> bool:
    if not isinstance(x, (int, float)) or isinstance(x, bool):
        return False
    try:
        return bool(np.isfinite(float(x)))
    except OverflowError:
        return False


def _load_json(p: Path) -> object:
    try:
        if p.stat().st_size > MAX_JSON_BYTES:
            raise InputError(f"larger than {MAX_JSON_BYTES >> 20} MB", path=p)
        with p.open(encoding="utf-8-sig") as f:
            return json.load(f)
    except FileNotFoundError:
        raise InputError("no such file", path=p) from None
    except UnicodeDecodeError:
        raise InputError("not a text JSON file (not UTF-8)", path=p) from None
    except json.JSONDecodeError as exc:
        raise InputError(f"not JSON: {exc.msg}", path=p, line=exc.lineno) from None
    except (OSError, RecursionError, ValueError) as exc:
        raise InputError(f"cannot read: {str(exc)[:80]}", path=p) from None
