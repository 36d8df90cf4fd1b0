"""Compressed glTF as avatars are delivered: buffers unpacked before any accessor is read.

Avatars from the web's pipelines (three.js, Ready Player Me, VRoid exports run through
gltfpack or glTF-Transform) are rarely plain glTF. This module turns such a file into plain
accessors over one binary blob, in place, so that :mod:`renderer.gltfio` reads it as any other:

- ``EXT_meshopt_compression``: each compressed bufferView is decoded by meshoptimizer's own
  decoder (the ``meshopt`` package binds its C++ sources), filters (octahedral, quaternion,
  exponential, colour) included; a fallback buffer without data is ignored.
- ``KHR_draco_mesh_compression``: each compressed primitive is decoded by Google's Draco
  (``DracoPy``) and its attributes and indices become new float32 / uint32 accessors. Morph
  targets are never Draco-compressed (the extension's spec), so they stay as they are.
- ``KHR_mesh_quantization``: integer and normalised accessors, which :mod:`renderer.gltfio`
  reads anyway; the dequantisation lives in node transforms, skin inverse bind matrices and
  ``KHR_texture_transform`` on the texture (:func:`texture_transform`).
- ``KHR_texture_basisu``: the texture's KTX2 source (ETC1S or UASTC) is transcoded to RGBA8 by
  Basis Universal's transcoder (``opengl_basisu``) (:func:`decode_ktx2`).
- ``EXT_texture_webp``: the texture's WebP source (VRoid Studio and glTF-Transform write them,
  often with no PNG fallback) is decoded by Pillow (:mod:`renderer.gltftexture`).

Anything else in ``extensionsRequired`` (glTF 2.0 sec. 3.12: a loader must refuse a file whose
required extension it does not know) is refused first, in one line that names the extension and
a command that converts the file (:data:`CONVERSIONS`).

Sources: the extensions' specifications in KhronosGroup/glTF (``extensions/2.0/``), and the
files gltfpack 1.3 and glTF-Transform 4.5 write (tests/renderer/data/, made by the script there).
"""

from __future__ import annotations

import base64
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError

#: Extensions a file may require that facepair reads (the rest of the file's look is PBR-lite).
READ: dict[str, str] = {
    "KHR_mesh_quantization": "quantised vertex attributes",
    "EXT_meshopt_compression": "meshoptimizer compression",
    "KHR_draco_mesh_compression": "Draco mesh compression",
    "KHR_texture_basisu": "KTX2 / Basis Universal textures",
    "EXT_texture_webp": "WebP textures",
    "KHR_texture_transform": "texture coordinate transforms",
    "KHR_materials_unlit": "unlit materials (drawn lit)",
    "KHR_materials_emissive_strength": "emissive strength (not drawn)",
}
#: A command that rewrites a file without the extension, for those facepair does not read.
CONVERSIONS: dict[str, str] = {
    "EXT_texture_avif": "gltf-transform png in.glb out.glb",
    "EXT_mesh_gpu_instancing": "gltf-transform flatten in.glb out.glb",
    "KHR_meshopt_compression": "gltfpack -i in.glb -o out.glb -noq",
}
_GENERIC = "gltfpack -i in.glb -o out.glb -noq (or export it again without the extension)"
#: Bytes the decoded views of one file may take (a head is a few MB; morph deltas compress well).
MAX_DECODED_BYTES = 1 << 30
#: Most a meshopt view may expand (the vertex codec spends at least one bit per byte of even an
#: all-zero stream, 64x; the files of tests/renderer/data expand at most 53x), checked before
#: the decoder allocates what a header claims.
MAX_RATIO = 256
_ALIGN = 16


def check_required(gltf: Any, path: Path) -> None:
    """Refuse a file that requires an extension facepair does not read, saying how to convert it.

    >>> class G: extensionsRequired = ["EXT_texture_avif"]
    >>> check_required(G(), Path("a.glb"))
    Traceback (most recent call last):
    ...
    app.errors.InputError: a.glb: requires the glTF extension EXT_texture_avif, which facepair \
does not read; convert the file first: gltf-transform png in.glb out.glb
    """
    for name in gltf.extensionsRequired or []:
        if name not in READ:
            how = CONVERSIONS.get(str(name), _GENERIC)
            raise InputError(
                f"requires the glTF extension {name}, which facepair does not read; "
                f"convert the file first: {how}",
                path=path,
            )


def _buffer_bytes(gltf: Any, index: int, glb: bytes, base: Path, path: Path) -> bytes:
    buf = gltf.buffers[index]
    uri = buf.uri
    if uri is None:
        fallback = (buf.extensions or {}).get("EXT_meshopt_compression") or {}
        return b"" if fallback.get("fallback") or index else glb
    if uri.startswith("data:"):
        try:
            return base64.b64decode(uri.split(",", 1)[1], validate=False)
        except (ValueError, IndexError):
            raise InputError(f"buffer {index}: malformed data URI", path=path) from None
    target = (base / uri).resolve()
    if not target.is_file() or base.resolve() not in target.parents:
        raise InputError(f"buffer {index}: {uri} is not a file beside the glTF", path=path)
    return target.read_bytes()


def unpack(gltf: Any, glb: bytes, path: Path) -> bytes:
    """One blob holding every bufferView, meshopt views decoded and Draco primitives unpacked.

    Rewrites ``gltf`` in place (bufferViews relocated into buffer 0, Draco attributes as plain
    accessors) and returns the blob.
    """
    import pygltflib

    buffers = [_buffer_bytes(gltf, i, glb, path.parent, path) for i in range(len(gltf.buffers))]
    parts: list[bytes] = []
    size = 0

    def append(data: bytes) -> int:
        nonlocal size
        at = size
        parts.append(data)
        pad = -len(data) % _ALIGN
        parts.append(b"\x00" * pad)
        size += len(data) + pad
        if size > MAX_DECODED_BYTES:
            raise InputError(
                f"decoded buffers exceed {MAX_DECODED_BYTES >> 20} MB: not an avatar", path=path
            )
        return at

    for i, view in enumerate(gltf.bufferViews):
        ext = (view.extensions or {}).get("EXT_meshopt_compression")
        if ext is not None:
            data = _meshopt_view(ext, buffers, i, path)
            view.byteStride = view.byteStride or int(ext["byteStride"])
            view.extensions = {
                k: v for k, v in view.extensions.items() if k != "EXT_meshopt_compression"
            }
        else:
            src = buffers[view.buffer]
            start, length = view.byteOffset or 0, view.byteLength
            if start + length > len(src):
                raise InputError(f"bufferView {i} reaches past its buffer", path=path)
            data = src[start : start + length]
        view.buffer, view.byteOffset, view.byteLength = 0, append(data), len(data)
    for m, mesh in enumerate(gltf.meshes):
        for p, prim in enumerate(mesh.primitives):
            draco = (prim.extensions or {}).get("KHR_draco_mesh_compression")
            if draco is not None:
                _unpack_draco(
                    gltf, prim, draco, b"".join(parts), append, f"mesh {m} prim {p}", path
                )
    blob = b"".join(parts)
    gltf.buffers = [pygltflib.Buffer(byteLength=len(blob))]
    return blob


def _meshopt_view(ext: dict[str, Any], buffers: list[bytes], i: int, path: Path) -> bytes:
    """A bufferView's bytes decoded by meshoptimizer (EXT_meshopt_compression, sec. "Bitstream")."""
    try:
        import meshopt
    except ImportError:
        raise InputError(
            "EXT_meshopt_compression needs the meshopt package (pip install meshopt), or "
            "convert the file: gltfpack -i in.glb -o out.glb -noq",
            path=path,
        ) from None
    try:
        src = buffers[int(ext["buffer"])]
        start, length = int(ext.get("byteOffset", 0)), int(ext["byteLength"])
        count, stride = int(ext["count"]), int(ext["byteStride"])
        mode, filt = str(ext["mode"]), str(ext.get("filter", "NONE"))
        if start + length > len(src):
            raise ValueError("the compressed data does not fit its buffer")
        if not 0 < count * stride <= min(MAX_RATIO * length + 65536, MAX_DECODED_BYTES):
            raise ValueError(f"{count} x {stride} bytes cannot come from {length} compressed")
        rows = meshopt.decode_gltf_buffer(src[start : start + length], count, stride, mode, filt)
    except (KeyError, TypeError, ValueError, IndexError, RuntimeError) as exc:
        raise InputError(
            f"bufferView {i}: meshopt data cannot be decoded: {exc}", path=path
        ) from None
    out = np.ascontiguousarray(rows)
    if mode != "ATTRIBUTES":  # index rows come back as integers of the view's width
        out = out.astype(np.uint16 if stride == 2 else np.uint32)
    return out.tobytes()


def _unpack_draco(gltf, prim, draco, blob: bytes, append, where: str, path: Path) -> None:
    """Replace a Draco-compressed primitive's accessors by plain ones (KHR_draco_mesh_compression).

    The decoded attributes are found by the unique ids the extension's ``attributes`` gives.
    """
    import pygltflib

    try:
        import DracoPy
    except ImportError:
        raise InputError(
            "KHR_draco_mesh_compression needs DracoPy (pip install DracoPy)", path=path
        ) from None
    try:
        view = gltf.bufferViews[int(draco["bufferView"])]
        start = view.byteOffset or 0
        mesh = DracoPy.decode(blob[start : start + view.byteLength])
    except Exception as exc:  # DracoPy raises its own failure types
        raise InputError(f"{where}: Draco data cannot be decoded: {exc}", path=path) from None

    def add(values: np.ndarray, accessor_index: int | None, kind: str) -> int:
        values = np.ascontiguousarray(values)
        width = 1 if values.ndim == 1 else values.shape[1]
        ctype = {
            np.dtype(np.float32): 5126,
            np.dtype(np.uint32): 5125,
            np.dtype(np.uint16): 5123,
            np.dtype(np.uint8): 5121,
        }[values.dtype]
        gltf.bufferViews.append(
            pygltflib.BufferView(
                buffer=0, byteOffset=append(values.tobytes()), byteLength=values.nbytes
            )
        )
        acc = pygltflib.Accessor(
            bufferView=len(gltf.bufferViews) - 1,
            componentType=ctype,
            count=len(values),
            type=kind if width > 1 or kind == "SCALAR" else "SCALAR",
        )
        if accessor_index is None:
            gltf.accessors.append(acc)
            return len(gltf.accessors) - 1
        gltf.accessors[accessor_index] = acc
        return accessor_index

    faces = np.asarray(mesh.faces, dtype=np.uint32).reshape(-1)
    prim.indices = add(faces, prim.indices, "SCALAR")
    n = len(np.asarray(mesh.points).reshape(-1, 3))
    if n == 0:
        raise InputError(f"{where}: Draco data holds no vertices", path=path)
    for name, unique in (draco.get("attributes") or {}).items():
        target = getattr(prim.attributes, name, None)
        if target is None:
            continue
        attr = mesh.get_attribute_by_unique_id(int(unique))
        if attr is None:
            raise InputError(f"{where}: Draco data lacks attribute {name}", path=path)
        data = np.asarray(attr["data"])
        data = data.reshape(n, -1) if data.size % n == 0 else data
        kind = gltf.accessors[target].type
        acc = gltf.accessors[target]
        widths: dict[int, np.dtype[Any]] = {5121: np.dtype(np.uint8), 5123: np.dtype(np.uint16)}
        dtype: np.dtype[Any] = (
            np.dtype(np.float32)
            if data.dtype.kind == "f"
            else widths.get(acc.componentType, np.dtype(np.uint32))
        )
        if data.dtype.kind != "f" and acc.normalized:  # normalised integers kept as fractions
            data = data / float(np.iinfo(dtype.str).max)
            dtype = np.dtype(np.float32)
        setattr(prim.attributes, name, add(data.astype(dtype), target, kind))
    prim.extensions = {
        k: v for k, v in prim.extensions.items() if k != "KHR_draco_mesh_compression"
    }


def texture_source(gltf: Any, texture_index: int) -> int | None:
    """The image a texture shows: its KHR_texture_basisu (KTX2) or EXT_texture_webp source
    first, else ``source`` (the fallback such a texture may carry)."""
    tex = gltf.textures[texture_index]
    for name in ("KHR_texture_basisu", "EXT_texture_webp"):
        ext = (tex.extensions or {}).get(name)
        if isinstance(ext, dict) and isinstance(ext.get("source"), int):
            return int(ext["source"])
    return tex.source


def decode_ktx2(data: bytes) -> np.ndarray:
    """A KTX2 texture (Basis Universal ETC1S or UASTC) as (h, w, 4) uint8 RGBA, level 0.

    >>> decode_ktx2(b"not ktx")
    Traceback (most recent call last):
    ...
    ValueError: not a KTX2 / Basis Universal texture
    """
    if data[:12] != b"\xabKTX 20\xbb\r\n\x1a\n":
        raise ValueError("not a KTX2 / Basis Universal texture")
    import opengl_basisu

    image = opengl_basisu.open(data).transcode("rgba8", level=0)
    return np.asarray(image.data, dtype=np.uint8).reshape(image.height, image.width, 4)


def texture_transform(info: Any, uv: np.ndarray) -> np.ndarray:
    """UVs through the texture's ``KHR_texture_transform`` (offset, rotation, scale), if any.

    The extension's matrix is ``T * R * S``: ``uv' = offset + R(rotation) (scale * uv)`` with
    ``R = [[cos, sin], [-sin, cos]]``. gltfpack stores quantised UVs as integers and their
    dequantisation here.

    >>> class I: extensions = {"KHR_texture_transform": {"offset": [0.5, 0], "scale": [2, 2]}}
    >>> texture_transform(I(), np.array([[0.25, 0.25]])).tolist()
    [[1.0, 0.5]]
    """
    tt = (getattr(info, "extensions", None) or {}).get("KHR_texture_transform")
    if not isinstance(tt, dict):
        return uv
    ox, oy = (list(tt.get("offset") or [0.0, 0.0]) + [0.0, 0.0])[:2]
    sx, sy = (list(tt.get("scale") or [1.0, 1.0]) + [1.0, 1.0])[:2]
    r = float(tt.get("rotation") or 0.0)
    c, s = np.cos(r), np.sin(r)
    u, v = uv[:, 0] * sx, uv[:, 1] * sy
    return np.stack([c * u + s * v + ox, -s * u + c * v + oy], axis=1)
