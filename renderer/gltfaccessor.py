"""glTF accessors as numpy arrays: typed, strided, sparse and normalised views of the binary blob.

An accessor (Khronos, glTF 2.0 sec. 3.6.2) names a bufferView, a component type and a width
(``SCALAR`` to ``MAT4``); its elements may be interleaved with others (``byteStride``), replaced
in part by a sparse substitution, or integers that stand for -1..1 or 0..1 (``normalized``, as
``KHR_mesh_quantization`` writes them). :func:`read_accessor` decodes one with numpy, checking
that it fits the blob, for :mod:`renderer.gltfio` and :mod:`renderer.gltfmaterial`;
:mod:`renderer.gltfwrite` encodes them with the same :data:`COMPONENT_TYPES`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.errors import InputError

#: glTF accessor component type -> numpy dtype (glTF 2.0 sec. 3.6.2.2).
COMPONENT_TYPES = {
    5120: np.int8,
    5121: np.uint8,
    5122: np.int16,
    5123: np.uint16,
    5125: np.uint32,
    5126: np.float32,
}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
#: Elements an accessor without data of its own may declare (all zeros but for sparse ones).
MAX_SPARSE_ELEMENTS = 10_000_000


def read_accessor(gltf, blob: bytes, index: int, path: Path) -> np.ndarray:
    """Accessor ``index`` as an (count, width) float64 or int array (normalised as declared)."""
    try:
        acc = gltf.accessors[index]
        dtype = np.dtype(COMPONENT_TYPES[acc.componentType])
        width = _WIDTH[acc.type]
        if not 0 <= acc.count <= len(blob) + MAX_SPARSE_ELEMENTS:
            raise ValueError(f"count {acc.count} does not fit the file")
        out = np.zeros((acc.count, width), dtype)
        if acc.bufferView is not None:
            view = gltf.bufferViews[acc.bufferView]
            start = (view.byteOffset or 0) + (acc.byteOffset or 0)
            stride = view.byteStride or dtype.itemsize * width
            need = start + stride * (acc.count - 1) + dtype.itemsize * width
            if acc.count and need > len(blob):
                raise ValueError("accessor reaches past its buffer")
            raw = np.frombuffer(blob, np.uint8, count=max(need - start, 0), offset=start)
            rows = (
                np.lib.stride_tricks.as_strided(
                    raw, (acc.count, dtype.itemsize * width), (stride, 1)
                )
                if acc.count
                else raw
            )
            out = np.ascontiguousarray(rows).view(dtype).reshape(acc.count, width)
        if acc.sparse is not None and acc.sparse.count:
            sp = acc.sparse
            idx = np.frombuffer(
                blob,
                COMPONENT_TYPES[sp.indices.componentType],
                sp.count,
                (gltf.bufferViews[sp.indices.bufferView].byteOffset or 0)
                + (sp.indices.byteOffset or 0),
            )
            vals = np.frombuffer(
                blob,
                dtype,
                sp.count * width,
                (gltf.bufferViews[sp.values.bufferView].byteOffset or 0)
                + (sp.values.byteOffset or 0),
            ).reshape(sp.count, width)
            out = out.copy()
            out[idx.astype(np.int64)] = vals
    except (IndexError, KeyError, ValueError, TypeError, AttributeError) as exc:
        raise InputError(f"accessor {index} cannot be read: {exc}", path=path) from None
    if acc.normalized and dtype.kind in "iu":
        return np.maximum(out / float(np.iinfo(dtype.str).max), -1.0)
    return out.astype(np.float64) if dtype.kind == "f" else out
