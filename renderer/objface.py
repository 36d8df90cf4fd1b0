"""Bring your own face: a Wavefront OBJ mesh plus a JSON file of MPEG-4 feature points.

The JSON file (format ``facepair-face/1``; documented in docs/reference/renderer.md)::

    {
      "format": "facepair-face/1",
      "mesh": "head.obj",                      # relative to the JSON file
      "feature_points": {"2.1": 812, ..., "7.1": [0.0, -40.0, -18.0]},
      "groups": {"eyeball_l": [..vertex indices..], "eyeball_r": [...]},
      "fapu": {"ES0": 62.0, ...},              # optional: measured from the points if absent
      "jaw_pivot": [0.0, -4.0, 10.0],          # optional
      "weights": {"head": [[index, weight], ...]},   # optional rig layers
      "name": "my head"                        # optional
    }

Feature points are 0-based vertex indices (they then follow the deformation) or ``[x, y, z]``
positions; the mouth points must be vertices (the mosaic follows them). Axes as in Xface:
+x the face's left, +y up, +z towards the viewer. Every problem is an
:class:`~app.errors.InputError` naming the file, the line (OBJ) or the field (JSON).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from renderer.face import (
    FAPU_NAMES,
    MOUTH_FEATURE_POINTS,
    OPTIONAL_GROUPS,
    REQUIRED_FEATURE_POINTS,
    REQUIRED_GROUPS,
    WEIGHT_LAYERS,
    Face,
    fapu_from_feature_points,
)

FORMAT = "facepair-face/1"
SKIN_RGB = (0.80, 0.60, 0.50)


def read_obj(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Vertices (n, 3), triangles (m, 3) and optional per-vertex RGB of an OBJ file.

    Polygons are split into fans; ``f`` entries may be ``v``, ``v/vt``, ``v//vn`` or
    ``v/vt/vn`` and negative (relative) indices. Colours come from ``v x y z r g b`` lines.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("mesh file not found", path=p)
    verts: list[list[float]] = []
    colours: list[list[float]] = []
    tris: list[tuple[int, int, int]] = []
    with p.open(encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            parts = line.split()
            if not parts or parts[0].startswith("#"):
                continue
            if parts[0] == "v":
                try:
                    nums = [float(x) for x in parts[1:]]
                except ValueError:
                    raise InputError(
                        f"vertex coordinates must be numbers: {line.strip()!r}", path=p, line=lineno
                    ) from None
                if len(nums) not in (3, 4, 6, 7) or not np.all(np.isfinite(nums)):
                    raise InputError(
                        "a vertex needs 3 finite coordinates (optionally r g b)",
                        path=p,
                        line=lineno,
                    )
                verts.append(nums[:3])
                if len(nums) >= 6:
                    colours.append(nums[-3:])
            elif parts[0] == "f":
                if len(parts) < 4:
                    raise InputError("a face needs at least 3 vertices", path=p, line=lineno)
                idx = []
                for token in parts[1:]:
                    try:
                        k = int(token.split("/")[0])
                    except ValueError:
                        raise InputError(
                            f"bad face vertex {token!r}", path=p, line=lineno
                        ) from None
                    k = k - 1 if k > 0 else len(verts) + k
                    if not 0 <= k < len(verts):
                        raise InputError(
                            f"face refers to vertex {token.split('/')[0]}, but "
                            f"only {len(verts)} are defined so far",
                            path=p,
                            line=lineno,
                        )
                    idx.append(k)
                tris.extend((idx[0], idx[i], idx[i + 1]) for i in range(1, len(idx) - 1))
    if len(verts) < 3 or not tris:
        raise InputError("no triangles: expected 'v' and 'f' lines", path=p)
    rgb = None
    if colours:
        if len(colours) != len(verts):
            raise InputError("either every vertex or none has a colour", path=p)
        rgb = np.clip(np.array(colours, dtype=np.float64), 0.0, 1.0)
    return np.array(verts), np.array(tris, dtype=np.int64), rgb


def _vertex_list(value: Any, n: int, path: Path, field: str) -> np.ndarray:
    if not isinstance(value, list) or not value:
        raise InputError("expected a non-empty list of vertex indices", path=path, field=field)
    if not all(isinstance(i, int) and not isinstance(i, bool) for i in value):
        raise InputError("vertex indices must be whole numbers", path=path, field=field)
    idx = np.array(value, dtype=np.int64)
    if idx.min() < 0 or idx.max() >= n:
        raise InputError(f"vertex index out of range 0..{n - 1}", path=path, field=field)
    return idx


def _point(
    value: Any, vertices: np.ndarray, path: Path, name: str
) -> tuple[np.ndarray, int | None]:
    field = f"feature_points.{name}"
    if isinstance(value, int) and not isinstance(value, bool):
        if not 0 <= value < len(vertices):
            raise InputError(
                f"vertex index {value} out of range 0..{len(vertices) - 1}", path=path, field=field
            )
        return vertices[value].astype(np.float64), value
    if (
        isinstance(value, list)
        and len(value) == 3
        and all(isinstance(x, int | float) and not isinstance(x, bool) for x in value)
    ):
        return np.array(value, dtype=np.float64), None
    raise InputError("expected a vertex index or [x, y, z]", path=path, field=field)


def paint_eyes(
    colors: np.ndarray,
    vertices: np.ndarray,
    groups: dict[str, np.ndarray],
    pupils: dict[str, np.ndarray],
) -> None:
    """Colour eyeball vertices as sclera, iris and pupil by their angle from the pupil point."""
    for side, key in (("l", "3.5"), ("r", "3.6")):
        idx = groups[f"eyeball_{side}"]
        v = vertices[idx]
        centre = (v.min(0) + v.max(0)) / 2
        axis = pupils[key] - centre
        axis /= max(np.linalg.norm(axis), 1e-12)
        d = v - centre
        ang = np.arccos(np.clip(d @ axis / np.maximum(np.linalg.norm(d, axis=1), 1e-12), -1, 1))
        rgb = np.where(
            ang[:, None] < 0.19,
            [0.03, 0.03, 0.03],
            np.where(ang[:, None] < 0.47, [0.30, 0.24, 0.17], [0.93, 0.91, 0.87]),
        )
        colors[idx, :3] = rgb
        colors[idx, 3] = 0.9


def load_face(json_path: str | Path) -> Face:
    """Read and validate a face JSON file and its OBJ mesh."""
    path = Path(json_path)
    spec = _read_spec(path)
    vertices, triangles, rgb = read_obj(path.parent / spec["mesh"])
    n = len(vertices)
    feature_points, fp_vertices = _feature_points(spec, vertices, path)
    groups = _groups(spec, n, path)
    fapu = _fapu(spec, feature_points, path)
    weights = _weights(spec, n, path)
    pivot = spec.get("jaw_pivot")
    if pivot is not None and not (isinstance(pivot, list) and len(pivot) == 3):
        raise InputError("expected [x, y, z]", path=path, field="jaw_pivot")

    colors = np.empty((n, 4))
    colors[:, :3] = rgb if rgb is not None else SKIN_RGB
    colors[:, 3] = 0.18
    paint_eyes(colors, vertices, groups, feature_points)
    return Face(
        vertices=vertices.astype(np.float32),
        triangles=triangles.astype(np.int32),
        colors=colors.astype(np.float32),
        feature_points=feature_points,
        fp_vertices=fp_vertices,
        fapu=fapu,
        groups=groups,
        weights=weights,
        jaw_pivot=None if pivot is None else np.array(pivot, dtype=np.float64),
        name=str(spec.get("name", path.stem)),
    )


def _read_spec(path: Path) -> dict[str, Any]:
    """The face JSON file as an object of the known format that names its OBJ mesh."""
    if not path.is_file():
        raise InputError("face file not found", path=path)
    try:
        spec = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON: {exc.msg}", path=path, line=exc.lineno) from None
    if not isinstance(spec, dict):
        raise InputError("expected a JSON object", path=path)
    if spec.get("format", FORMAT) != FORMAT:
        raise InputError(
            f"unknown format {spec.get('format')!r}, expected {FORMAT!r}", path=path, field="format"
        )
    if not isinstance(spec.get("mesh"), str):
        raise InputError("missing: the OBJ file name", path=path, field="mesh")
    return spec


def _feature_points(
    spec: dict[str, Any], vertices: np.ndarray, path: Path
) -> tuple[dict[str, np.ndarray], dict[str, int]]:
    """Every feature point's position, and the vertex of those given as vertices (all the
    required points present, the mouth's as vertices)."""
    fps_in = spec.get("feature_points")
    if not isinstance(fps_in, dict):
        raise InputError(
            "missing: an object of feature point -> vertex index", path=path, field="feature_points"
        )
    missing = [k for k in REQUIRED_FEATURE_POINTS if k not in fps_in]
    if missing:
        raise InputError(
            f"missing feature points: {', '.join(missing)}", path=path, field="feature_points"
        )
    feature_points: dict[str, np.ndarray] = {}
    fp_vertices: dict[str, int] = {}
    for name, value in fps_in.items():
        feature_points[name], vid = _point(value, vertices, path, name)
        if vid is not None:
            fp_vertices[name] = vid
    not_vertices = [k for k in MOUTH_FEATURE_POINTS if k not in fp_vertices]
    if not_vertices:
        raise InputError(
            f"mouth points must be vertex indices: {', '.join(not_vertices)}",
            path=path,
            field="feature_points",
        )
    return feature_points, fp_vertices


def _groups(spec: dict[str, Any], n: int, path: Path) -> dict[str, np.ndarray]:
    """The vertex groups the renderer knows, the required ones present."""
    groups_in = spec.get("groups")
    if not isinstance(groups_in, dict):
        raise InputError(
            "missing: vertex groups eyeball_l and eyeball_r", path=path, field="groups"
        )
    missing = [name for name in REQUIRED_GROUPS if name not in groups_in]
    if missing:
        raise InputError("missing group", path=path, field=f"groups.{missing[0]}")
    return {
        name: _vertex_list(groups_in[name], n, path, f"groups.{name}")
        for name in REQUIRED_GROUPS + OPTIONAL_GROUPS
        if name in groups_in
    }


def _fapu(
    spec: dict[str, Any], feature_points: dict[str, np.ndarray], path: Path
) -> dict[str, float]:
    """The FAPU measured from the feature points, replaced by those the file gives; all
    positive."""
    fapu = fapu_from_feature_points(feature_points)
    given = spec.get("fapu", {})
    if not isinstance(given, dict):
        raise InputError("expected an object of FAPU name -> distance", path=path, field="fapu")
    for name, value in given.items():
        if name not in FAPU_NAMES:
            raise InputError(
                f"unknown FAPU (expected one of {', '.join(FAPU_NAMES)})",
                path=path,
                field=f"fapu.{name}",
            )
        if not isinstance(value, int | float) or isinstance(value, bool) or not value > 0:
            raise InputError("must be a positive number", path=path, field=f"fapu.{name}")
        fapu[name] = float(value)
    bad = [k for k, v in fapu.items() if not v > 0]
    if bad:
        raise InputError(
            f"FAPU {', '.join(bad)} measured from the feature points is not "
            "positive: check the axes (+y up, +x the face's left) and the points",
            path=path,
            field="feature_points",
        )
    return fapu


def _weights(spec: dict[str, Any], n: int, path: Path) -> dict[str, np.ndarray]:
    """The rig's weight layers the file gives, each a weight per vertex (the layer's default,
    1 for ``head`` and 0 for the others, where the file gives none)."""
    weights: dict[str, np.ndarray] = {}
    for name, pairs in (spec.get("weights") or {}).items():
        field = f"weights.{name}"
        if name not in WEIGHT_LAYERS:
            raise InputError(
                f"unknown layer (expected one of {', '.join(WEIGHT_LAYERS)})",
                path=path,
                field=field,
            )
        arr = np.full(n, 1.0 if name == "head" else 0.0)
        try:
            idx = np.array([int(i) for i, _ in pairs])
            w = np.array([float(x) for _, x in pairs])
        except (TypeError, ValueError):
            raise InputError(
                "expected a list of [vertex index, weight] pairs", path=path, field=field
            ) from None
        if len(idx) and (idx.min() < 0 or idx.max() >= n or w.min() < 0 or w.max() > 1):
            raise InputError(
                "indices must be vertices and weights within 0..1", path=path, field=field
            )
        arr[idx] = w
        weights[name] = arr
    return weights


def write_face(face: Face, json_path: str | Path) -> Path:
    """Write ``face`` as an OBJ + face JSON pair (``<name>.obj`` beside the JSON file)."""
    path = Path(json_path)
    obj = path.with_suffix(".obj")
    lines = [
        f"v {x:.5f} {y:.5f} {z:.5f} {r:.4f} {g:.4f} {b:.4f}"
        for (x, y, z), (r, g, b) in zip(face.vertices, face.colors[:, :3], strict=True)
    ]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in face.triangles]
    obj.write_text("\n".join(lines) + "\n", encoding="utf-8")
    spec: dict[str, Any] = {
        "format": FORMAT,
        "mesh": obj.name,
        "name": face.name,
        "feature_points": {
            k: (
                face.fp_vertices[k]
                if k in face.fp_vertices
                else [float(x) for x in face.feature_points[k]]
            )
            for k in sorted(face.feature_points)
        },
        "groups": {k: [int(i) for i in v] for k, v in face.groups.items()},
        "fapu": {k: float(v) for k, v in face.fapu.items()},
    }
    layers = {}
    for name, arr in face.weights.items():
        default = 1.0 if name == "head" else 0.0
        idx = np.flatnonzero(np.abs(np.asarray(arr) - default) > 1e-6)
        layers[name] = [[int(i), round(float(arr[i]), 5)] for i in idx]
    if layers:
        spec["weights"] = layers
    if face.jaw_pivot is not None:
        spec["jaw_pivot"] = [float(x) for x in face.jaw_pivot]
    path.write_text(json.dumps(spec, indent=1) + "\n", encoding="utf-8")
    return path
