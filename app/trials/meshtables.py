"""The study file's mesh tables: how its mesh and FLAME sequences are read.

A study whose conditions (``tracks``) or ground truths are vertex sequences or FLAME parameters
(:mod:`app.stimuli.meshes`) says how to read them in a top-level ``[meshes]`` table, which every
such file of the study follows, and a condition may override it in its own ``mesh`` table::

    mesh_eyes = "match"          # the eyes beside a mesh: match (default) or own

    [meshes]
    fps = 30                     # the sequences' frame rate (the files do not say it)
    units = "auto"               # auto, m, cm, mm or biwi
    template = "FLAME_sample.ply"  # else the template beside each file, under its name
    regions = "FLAME_masks.pkl"  # lip and upper-face vertices (LVE, FDD, the mosaic)
    flame_model = "flame2023.pkl"  # your own FLAME model, for FLAME parameter files

    [[conditions]]
    name = "faceformer"
    tracks = { s2 = "ff/s2.npy" }
    mesh = { fps = 25, units = "biwi", template = "BIWI.ply" }

Paths resolve against the study file's folder like every other; ``regions`` may also name a
folder holding CodeTalker's ``lve.txt`` and ``fdd.txt`` (not in an uploaded study file).
Every key is documented in docs/reference/studyfile.md and docs/reference/meshes.md.

Example
-------
>>> from app.trials.fields import FieldReader
>>> reader = FieldReader("study.toml", Path("."), check_files=False)
>>> read_mesh_table(reader, {"fps": 25, "units": "biwi"}, "meshes")
{'fps': 25.0, 'units': 'biwi'}
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Final

from app.trials.fields import FieldReader

#: Keys of ``[meshes]`` and of a condition's ``mesh`` table.
MESH_KEYS: Final = ("fps", "units", "template", "regions", "flame_model")
#: ``app.stimuli.meshes.vertexfile.UNITS`` and ``auto``, repeated so that reading a study file
#: reads no mesh code.
MESH_UNITS: Final = ("auto", "m", "cm", "mm", "biwi")
TEMPLATE_SUFFIXES: Final = (".obj", ".ply")
REGION_SUFFIXES: Final = (".txt", ".json", ".npy", ".npz", ".pkl")
FLAME_SUFFIXES: Final = (".pkl", ".npz")


def read_mesh_table(reader: FieldReader, data: Any, name: str) -> dict[str, Any]:
    """The options of a ``[meshes]`` or ``mesh`` table, its paths resolved (as strings)."""
    table: Mapping[str, Any] = reader.table(data, name, MESH_KEYS)
    out: dict[str, Any] = {}
    if "fps" in table:
        fps = reader.get(table, "fps", f"{name}.fps", (int, float), "a number (frames a second)")
        if not 0 < fps <= 1000:
            raise reader.error(f"{name}.fps", f"must be a frame rate above 0, got {fps!r}")
        out["fps"] = float(fps)
    if "units" in table:
        out["units"] = reader.choice(table, "units", f"{name}.units", MESH_UNITS)
    if "template" in table:
        path = reader.file(table, "template", f"{name}.template", TEMPLATE_SUFFIXES)
        out["template"] = str(path)
    if "regions" in table:
        out["regions"] = _regions(reader, table, f"{name}.regions")
    if "flame_model" in table:
        path = reader.file(table, "flame_model", f"{name}.flame_model", FLAME_SUFFIXES)
        out["flame_model"] = str(path)
    return out


def _regions(reader: FieldReader, table: Mapping[str, Any], name: str) -> str:
    value = reader.text(table, "regions", name, nonempty=True)
    if Path(value).suffix:
        return str(reader.file(table, "regions", name, REGION_SUFFIXES))
    if reader.by_name:
        raise reader.error(name, "an uploaded study file names a region file, not a folder")
    folder = Path(os.path.abspath(reader.base_dir / value))
    if reader.check_files and not folder.is_dir():
        raise reader.error(name, f"no such folder: {str(folder)!r}")
    return str(folder)
