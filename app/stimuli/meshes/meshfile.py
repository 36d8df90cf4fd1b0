"""Template meshes: the vertices and triangles of a face in OBJ or PLY.

The talking-head projects render their vertex sequences on a template of the same topology:
VOCASET's ``FLAME_sample.ply`` (5,023 vertices; TimoBolkart/voca ``template/``) and BIWI's
``BIWI.ply`` (23,370 vertices, 46,068 triangles, binary little-endian with ``float x, y, z`` and
``list uchar int vertex_indices``: EvelynFan/FaceFormer ``BIWI/templates/BIWI.ply``), read by
``psbody.mesh.Mesh`` in FaceFormer's, CodeTalker's and SelfTalk's ``render.py``; EMOTE writes
per-frame OBJ files from its ``head_template.obj`` (radekd91/inferno
``inferno_apps/TalkingHead/evaluation/evaluation_functions.py``). :func:`read_mesh` reads:

* **OBJ**: ``v x y z`` lines (a fourth value or vertex colours after them are ignored) and
  ``f`` lines of three or more corners, each ``i``, ``i/t``, ``i/t/n`` or ``i//n``, negative
  indices counting back from the last vertex; polygons are split into a fan of triangles;
* **PLY** 1.0: ``ascii``, ``binary_little_endian`` and ``binary_big_endian``; the ``vertex``
  element's ``x``, ``y``, ``z`` of any numeric type, the ``face`` element's list property
  (``vertex_indices`` or ``vertex_index``) of any count and index type, other elements and
  properties skipped.

Every problem is one :class:`~app.errors.InputError` naming the file (and the line where there
is one).

Example
-------
>>> import io
>>> mesh = read_mesh(io.StringIO("v 0 0 0\\nv 1 0 0\\nv 1 1 0\\nv 0 1 0\\nf 1 2 3 4\\n"), "sq.obj")
>>> mesh.vertices.shape, mesh.triangles.tolist()
((4, 3), [[0, 1, 2], [0, 2, 3]])
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from app.errors import InputError

#: Template suffixes, in the order a vertex file's sibling is looked for.
MESH_SUFFIXES: tuple[str, ...] = (".obj", ".ply")

_PLY_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}


@dataclass(frozen=True)
class TriangleMesh:
    """Vertices (V, 3) float64 and triangles (F, 3) int32 (counter-clockwise seen from outside,
    as the file gives them)."""

    vertices: np.ndarray
    triangles: np.ndarray


def read_mesh(source: str | Path | IO[str] | IO[bytes], name: str | None = None) -> TriangleMesh:
    """Read an OBJ or PLY file (by its suffix, or by its first line for a stream)."""
    label = name or str(source)
    if isinstance(source, (str, Path)):
        try:
            data = Path(source).read_bytes()
        except FileNotFoundError:
            raise InputError("no such template mesh", path=label) from None
        except OSError as exc:
            raise InputError(f"cannot read the template mesh: {exc.strerror}", path=label) from None
    else:
        raw = source.read()
        data = raw.encode("latin-1") if isinstance(raw, str) else raw
    if data.startswith(b"ply"):
        mesh = _read_ply(data, label)
    elif Path(label).suffix.lower() == ".ply":
        raise InputError("not a PLY file (no 'ply' first line)", path=label)
    else:
        mesh = _read_obj(data, label)
    return _checked(mesh, label)


def _checked(mesh: TriangleMesh, label: str) -> TriangleMesh:
    v, t = mesh.vertices, mesh.triangles
    if len(v) < 3:
        raise InputError(f"a template needs vertices, got {len(v)}", path=label)
    if not len(t):
        raise InputError("the template has no faces (triangles)", path=label)
    if not np.isfinite(v).all():
        raise InputError("the template has a vertex that is not a finite number", path=label)
    if t.min() < 0 or t.max() >= len(v):
        raise InputError(
            f"a face names vertex {int(t.max()) + 1 if t.max() >= len(v) else int(t.min())} "
            f"of {len(v)}",
            path=label,
        )
    return mesh


def _fan(polygons: list[list[int]]) -> np.ndarray:
    tris = [(p[0], p[k], p[k + 1]) for p in polygons for k in range(1, len(p) - 1)]
    return np.array(tris, dtype=np.int64).reshape(-1, 3)


def _read_obj(data: bytes, label: str) -> TriangleMesh:
    vertices: list[tuple[float, float, float]] = []
    polygons: list[list[int]] = []
    for number, raw in enumerate(io.StringIO(data.decode("latin-1")), start=1):
        parts = raw.split()
        if not parts or parts[0] not in ("v", "f"):
            continue
        if parts[0] == "v":
            try:
                x, y, z = (float(p) for p in parts[1:4])
            except ValueError:
                raise InputError("expected 'v x y z'", path=label, line=number) from None
            vertices.append((x, y, z))
            continue
        corners = []
        for token in parts[1:]:
            try:
                index = int(token.split("/")[0])
            except ValueError:
                raise InputError(f"bad face corner {token!r}", path=label, line=number) from None
            if index == 0:
                raise InputError("face corner 0: OBJ counts from 1", path=label, line=number)
            corners.append(index - 1 if index > 0 else len(vertices) + index)
        if len(corners) < 3:
            raise InputError("a face needs three corners", path=label, line=number)
        polygons.append(corners)
    if not vertices:
        raise InputError("no 'v' lines: not an OBJ mesh", path=label)
    return TriangleMesh(np.array(vertices, dtype=np.float64), _fan(polygons).astype(np.int32))


@dataclass
class _Element:
    name: str
    count: int
    properties: list[tuple[str, str, str | None]]  # (name, type, list index type)


def _ply_header(data: bytes, label: str) -> tuple[str, list[_Element], int]:
    end = data.find(b"end_header")
    if end < 0:
        raise InputError("a PLY file without 'end_header'", path=label)
    stop = data.find(b"\n", end) + 1 or len(data)
    lines = data[:stop].decode("latin-1").splitlines()
    fmt = ""
    elements: list[_Element] = []
    for number, line in enumerate(lines, start=1):
        parts = line.split()
        if not parts or parts[0] in ("ply", "comment", "obj_info", "end_header"):
            continue
        if parts[0] == "format" and len(parts) >= 2:
            fmt = parts[1]
        elif parts[0] == "element" and len(parts) == 3 and parts[2].isdigit():
            elements.append(_Element(parts[1], int(parts[2]), []))
        elif parts[0] == "property" and elements:
            if parts[1] == "list" and len(parts) == 5:
                elements[-1].properties.append((parts[4], parts[3], parts[2]))
            elif len(parts) == 3:
                elements[-1].properties.append((parts[2], parts[1], None))
            else:
                raise InputError("bad property line", path=label, line=number)
        else:
            raise InputError(f"unexpected header line {line.strip()!r}", path=label, line=number)
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise InputError(f"unknown PLY format {fmt!r}", path=label)
    for element in elements:
        for prop, kind, count_kind in element.properties:
            for k in (kind, count_kind):
                if k is not None and k not in _PLY_TYPES:
                    raise InputError(f"unknown PLY type {k!r} of {prop}", path=label)
    return fmt, elements, stop


def _read_ply(data: bytes, label: str) -> TriangleMesh:
    fmt, elements, offset = _ply_header(data, label)
    names = [e.name for e in elements]
    if "vertex" not in names or "face" not in names:
        raise InputError("a PLY template needs 'vertex' and 'face' elements", path=label)
    reader = _PlyAscii(data[offset:], label) if fmt == "ascii" else None
    endian = "<" if fmt == "binary_little_endian" else ">"
    vertices = triangles = None
    for element in elements:
        rows: dict[str, Any]
        if reader is not None:
            rows = reader.element(element)
        else:
            rows, offset = _binary_element(data, offset, element, endian, label)
        if element.name == "vertex":
            try:
                vertices = np.column_stack([rows[k] for k in ("x", "y", "z")]).astype(np.float64)
            except KeyError:
                raise InputError("the vertex element lacks x, y or z", path=label) from None
        elif element.name == "face":
            lists = rows.get("vertex_indices", rows.get("vertex_index"))
            if lists is None:
                raise InputError("the face element lacks vertex_indices", path=label)
            triangles = _fan([list(map(int, p)) for p in lists]).astype(np.int32)
    assert vertices is not None and triangles is not None
    return TriangleMesh(vertices, triangles)


class _PlyAscii:
    def __init__(self, body: bytes, label: str) -> None:
        self.tokens = body.decode("latin-1").split()
        self.at, self.label = 0, label

    def _take(self, n: int) -> list[str]:
        if self.at + n > len(self.tokens):
            raise InputError("the PLY body ends early", path=self.label)
        out = self.tokens[self.at : self.at + n]
        self.at += n
        return out

    def element(self, element: _Element) -> dict[str, list]:
        out: dict[str, list] = {p[0]: [] for p in element.properties}
        try:
            for _ in range(element.count):
                for name, _kind, count_kind in element.properties:
                    if count_kind is None:
                        out[name].append(float(self._take(1)[0]))
                    else:
                        n = int(self._take(1)[0])
                        out[name].append([int(float(v)) for v in self._take(n)])
        except ValueError:
            raise InputError("a PLY value is not a number", path=self.label) from None
        return out


def _binary_element(
    data: bytes, offset: int, element: _Element, endian: str, label: str
) -> tuple[dict[str, list | np.ndarray], int]:
    props = element.properties
    if all(c is None for _, _, c in props):
        dtype = np.dtype([(n, endian + _PLY_TYPES[k]) for n, k, _ in props])
        size = dtype.itemsize * element.count
        if offset + size > len(data):
            raise InputError("the PLY body ends early", path=label)
        rows = np.frombuffer(data, dtype=dtype, count=element.count, offset=offset)
        return {n: rows[n] for n, _, _ in props}, offset + size
    out: dict[str, list | np.ndarray] = {}
    single = (
        len(props) == 1 and props[0][2] is not None and element.count > 0 and offset < len(data)
    )
    if single:  # the common face element: one list; fixed-length lists read in one go
        name, kind, count_kind = props[0]
        assert count_kind is not None
        ct, it = np.dtype(endian + _PLY_TYPES[count_kind]), np.dtype(endian + _PLY_TYPES[kind])
        n = int(np.frombuffer(data, dtype=ct, count=1, offset=offset)[0])
        dtype = np.dtype([("n", ct), ("i", it, (n,))])
        if n >= 3 and offset + dtype.itemsize * element.count <= len(data):
            rows = np.frombuffer(data, dtype=dtype, count=element.count, offset=offset)
            if (rows["n"] == n).all():
                out[name] = rows["i"]
                return out, offset + dtype.itemsize * element.count
    columns: dict[str, list] = {p[0]: [] for p in props}
    for _ in range(element.count):
        for name, kind, count_kind in props:
            t = np.dtype(endian + _PLY_TYPES[kind])
            if count_kind is None:
                if offset + t.itemsize > len(data):
                    raise InputError("the PLY body ends early", path=label)
                columns[name].append(np.frombuffer(data, t, 1, offset)[0])
                offset += t.itemsize
                continue
            ct = np.dtype(endian + _PLY_TYPES[count_kind])
            if offset + ct.itemsize > len(data):
                raise InputError("the PLY body ends early", path=label)
            n = int(np.frombuffer(data, ct, 1, offset)[0])
            offset += ct.itemsize
            if offset + n * t.itemsize > len(data):
                raise InputError("the PLY body ends early", path=label)
            columns[name].append(np.frombuffer(data, t, n, offset).tolist())
            offset += n * t.itemsize
    return dict(columns), offset


def write_obj(path: str | Path, vertices: np.ndarray, triangles: np.ndarray) -> Path:
    """Write a minimal OBJ (for tests and examples): ``v`` and ``f`` lines, 1-based."""
    out = Path(path)
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in np.asarray(vertices, dtype=np.float64)]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.asarray(triangles, dtype=np.int64)]
    out.write_text("\n".join(lines) + "\n", encoding="ascii")
    return out


def write_ply(path: str | Path, vertices: np.ndarray, triangles: np.ndarray) -> Path:
    """Write a binary little-endian PLY as BIWI.ply is laid out (float x, y, z; uchar-counted
    int lists)."""
    v = np.asarray(vertices, dtype="<f4")
    t = np.asarray(triangles, dtype="<i4")
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment written by facepair\n"
        f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(t)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    faces = np.zeros(len(t), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"], faces["i"] = 3, t
    out = Path(path)
    out.write_bytes(header.encode("ascii") + v.tobytes() + faces.tobytes())
    return out
