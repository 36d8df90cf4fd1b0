"""Ground truth from capture: trackers' and tools' files to FAPs, and the thesis' own marker
pipeline from IR video (:mod:`~app.stimuli.capture.markers`).

Formats (:data:`FORMATS`; mappings, units, signs and sources in the importer modules and
docs/reference/capture.md):

* ``openface``: OpenFace 2.0 FeatureExtraction CSV (:mod:`~app.stimuli.capture.openface`);
* ``arkit``: ARKit blendshape CSV in Live Link Face's layout, as the app and the tools that
  copy it write it (:mod:`~app.stimuli.capture.arkit`);
* ``a2f-csv``: NVIDIA Audio2Face-3D's ``animation_frames.csv`` (``timeCode``,
  ``blendShapes.<name>``); ``a2f-json``: Audio2Face's blendshape-weights JSON
  (``facsNames``, ``weightMat``, ``exportFps``), also written by OpenFaceFX;
  ``openfacefx-json`` / ``openfacefx-csv``: OpenFaceFX's own keyframe tracks with ARKit
  channels (:mod:`~app.stimuli.capture.weights`);
* ``bvh``: a BVH skeleton's head and neck (GENEA's gesture data; :mod:`~app.stimuli.capture.bvh`).

:func:`sniff` tells them apart by header (CSV), by content (JSON) or by extension (BVH);
:func:`sniff_csv` tells a tracker's CSV from facepair's own track CSV, so every place that
reads a ground truth takes these CSVs as they are.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import TYPE_CHECKING, Any

from app.errors import InputError

if TYPE_CHECKING:
    from app.stimuli.track import MotionTrack

#: Formats facepair imports.
FORMATS = ("openface", "arkit", "a2f-csv", "a2f-json", "openfacefx-json", "openfacefx-csv", "bvh")


def sniff_csv(path: str | Path) -> str | None:
    """``"openface"``, ``"arkit"``, ``"a2f-csv"``, ``"openfacefx-csv"`` or ``None`` (not a
    tracker's CSV) from the header line."""
    from app.stimuli.capture.arkit import is_arkit
    from app.stimuli.capture.openface import is_openface
    from app.stimuli.capture.weights import is_a2f_csv, is_openfacefx_csv

    try:
        with Path(path).open(newline="", encoding="utf-8-sig") as f:
            first = f.readline(65536)
    except (OSError, UnicodeDecodeError):
        return None
    try:
        header = [h.strip() for h in next(csv.reader([first], skipinitialspace=True), [])]
    except csv.Error:
        return None
    if is_openface(header):
        return "openface"
    if is_arkit(header):
        return "arkit"
    if is_a2f_csv(header):
        return "a2f-csv"
    if is_openfacefx_csv(header):
        return "openfacefx-csv"
    return None


def sniff(path: str | Path) -> str | None:
    """The format of ``path`` (one of :data:`FORMATS`) or ``None``: a CSV by its header, a
    BVH by its first word (``HIERARCHY``) or extension, a JSON by its keys."""
    p = Path(path)
    try:
        with p.open("rb") as f:
            start = f.read(4096)
    except OSError:
        return None
    head = start.lstrip(b"\xef\xbb\xbf \t\r\n")
    if head[:9].upper() == b"HIERARCHY" or p.suffix.lower() == ".bvh":
        return "bvh"
    if head[:1] == b"{" or p.suffix.lower() == ".json":
        from app.stimuli.capture.weights import json_kind

        return json_kind(p)
    return sniff_csv(p)


def import_track(
    path: str | Path, kind: str | None = None, fps: float = 30.0, **options: Any
) -> MotionTrack:
    """Read a tracker's or a tool's file as a FAP track at ``fps``; ``kind`` None detects it.

    ``options`` pass on where they apply: ``max_gap_s``; ``min_confidence``, ``neutral`` and
    ``gaze_neutral`` (OpenFace); ``flip`` (ARKit rotation columns) and ``brow_neutral``
    (ARKit); ``neutral`` (BVH).
    """
    from app.stimuli.capture import arkit, bvh, openface, weights

    kind = kind or sniff(path)
    gap = {k: options[k] for k in ("max_gap_s",) if options.get(k) is not None}
    if kind == "openface":
        keys = ("min_confidence", "neutral", "gaze_neutral")
        extra = {k: options[k] for k in keys if options.get(k)}
        return openface.read_openface(path, fps, **gap, **extra)
    if kind == "arkit":
        mapping = arkit.arkit_mapping(flip=options.get("flip") or ())
        brows = {"brow_neutral": options["brow_neutral"]} if options.get("brow_neutral") else {}
        return arkit.read_arkit_csv(path, fps, mapping=mapping, **gap, **brows)
    if kind == "a2f-csv":
        return weights.read_a2f_csv(path, fps, **gap)
    if kind == "a2f-json":
        return weights.read_a2f_json(path, fps, **gap)
    if kind == "openfacefx-json":
        return weights.read_openfacefx_json(path, fps, **gap)
    if kind == "openfacefx-csv":
        return weights.read_openfacefx_csv(path, fps, **gap)
    if kind == "bvh":
        return bvh.read_bvh(path, fps, neutral=options.get("neutral"), **gap)
    raise InputError(
        f"not a file facepair imports ({', '.join(FORMATS)}): neither its header nor its "
        "extension says which tool wrote it",
        path=path,
        line=1,
    )
