"""A glTF primitive's look: base colour textures sampled per vertex and per pixel, a texture's
fallback source, and any image bytes or channel layout read or refused in one line."""

import io
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pygltflib
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from renderer.gltfio import read_gltf

DATA = Path(__file__).parent / "data"


def _edited(exported_head, path, edit):
    gltf = pygltflib.GLTF2().load_binary(str(exported_head))
    edit(gltf)
    gltf.save_binary(str(path))
    return path


def test_base_colour_texture_is_sampled_at_each_vertex(exported_head, tmp_path):
    png = io.BytesIO()
    iio.imwrite(png, np.array([[[255, 0, 0], [0, 0, 255]]], np.uint8), extension=".png")

    def texture(gltf):
        blob = bytearray(gltf.binary_blob())
        n = gltf.accessors[0].count
        x = np.frombuffer(
            bytes(blob),
            np.float32,
            n * 3,
            gltf.bufferViews[gltf.accessors[0].bufferView].byteOffset,
        )[0::3]
        uv = np.column_stack([np.where(x > 0, 0.0, 1.0), np.zeros(n)]).astype(np.float32)
        for data, kind, count in ((uv.tobytes(), "VEC2", n), (png.getvalue(), None, None)):
            while len(blob) % 4:
                blob.append(0)
            gltf.bufferViews.append(
                pygltflib.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data))
            )
            blob.extend(data)
            if kind:
                gltf.accessors.append(
                    pygltflib.Accessor(
                        bufferView=len(gltf.bufferViews) - 1,
                        componentType=pygltflib.FLOAT,
                        count=count,
                        type=kind,
                    )
                )
        prim = gltf.meshes[0].primitives[0]
        prim.attributes.TEXCOORD_0 = len(gltf.accessors) - 1
        prim.attributes.COLOR_0 = None
        gltf.images = [pygltflib.Image(bufferView=len(gltf.bufferViews) - 1, mimeType="image/png")]
        gltf.textures = [pygltflib.Texture(source=0)]
        gltf.materials[0].pbrMetallicRoughness.baseColorTexture = pygltflib.TextureInfo(index=0)
        gltf.buffers[0].byteLength = len(blob)
        gltf.set_binary_blob(bytes(blob))

    scene = read_gltf(_edited(exported_head, tmp_path / "t.glb", texture))
    left = scene.vertices[:, 0] > 0
    assert np.allclose(scene.colors[left, :3], (1, 0, 0))
    assert np.allclose(scene.colors[~left, :3], (0, 0, 1))


def test_a_ktx2_texture_that_fails_falls_back_to_the_textures_own_source(tmp_path):
    import json
    import struct

    raw = (DATA / "head-gltfpack.glb").read_bytes()
    n = struct.unpack("<I", raw[12:16])[0]
    doc, blob = json.loads(raw[20 : 20 + n]), raw[28 + n :]
    broken = b"\xabKTX 20\xbb\r\n\x1a\n" + bytes(64)  # a KTX2 signature, nothing usable
    doc["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(broken)})
    doc["buffers"][0]["byteLength"] = len(blob) + len(broken)
    doc["images"].append({"bufferView": len(doc["bufferViews"]) - 1, "mimeType": "image/ktx2"})
    doc["textures"][0]["extensions"] = {"KHR_texture_basisu": {"source": len(doc["images"]) - 1}}
    doc["extensionsUsed"].append("KHR_texture_basisu")
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    blob += broken + b"\x00" * (-len(broken) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text
    body += struct.pack("<I4s", len(blob), b"BIN\x00") + blob
    (tmp_path / "a.glb").write_bytes(b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body)
    fallback, png = read_gltf(tmp_path / "a.glb"), read_gltf(DATA / "head-gltfpack.glb")
    np.testing.assert_array_equal(fallback.texture, png.texture)


def _with_image(source: Path, path: Path, data: bytes, mime: str = "image/png") -> Path:
    """``source`` with its (first) image's bytes replaced by ``data``, in a buffer of its own
    appended to the binary chunk."""
    gltf = pygltflib.GLTF2().load_binary(str(source))
    blob = bytearray(gltf.binary_blob())
    while len(blob) % 4:
        blob.append(0)
    gltf.bufferViews.append(
        pygltflib.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data))
    )
    blob.extend(data)
    gltf.buffers[0].byteLength = len(blob)
    gltf.images[0].bufferView = len(gltf.bufferViews) - 1
    gltf.images[0].mimeType = mime
    gltf.set_binary_blob(bytes(blob))
    gltf.save_binary(str(path))
    return path


@settings(
    max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.binary(min_size=0, max_size=400), mime=st.sampled_from(["image/png", "image/webp"]))
def test_a_texture_of_any_bytes_is_one_line_naming_it(exported_head, tmp_path, data, mime):
    path = _with_image(exported_head, tmp_path / "t.glb", data, mime)
    try:
        scene = read_gltf(path)
    except InputError as exc:
        line = str(exc)
        assert line.startswith(f"{path}: texture 0: image 0 cannot be read") and "\n" not in line
    else:
        assert scene.texture is not None


@pytest.mark.parametrize(
    ("mode", "fmt"), [("LA", "PNG"), ("RGBA", "WEBP"), ("P", "PNG"), ("I;16", "PNG")]
)
def test_a_texture_in_any_channel_layout_reads(exported_head, tmp_path, mode, fmt):
    """A grey-and-alpha PNG crashed (its two channels did not broadcast); WebP was refused."""
    from PIL import Image

    grey = np.tile(np.linspace(0, 255, 64).astype(np.uint8), (32, 1))
    image = {
        "LA": Image.fromarray(np.dstack([grey, np.full_like(grey, 255)]), "LA"),
        "RGBA": Image.fromarray(np.dstack([grey, grey, grey, np.full_like(grey, 255)]), "RGBA"),
        "P": Image.fromarray(grey, "L").convert("P"),
        "I;16": Image.fromarray(grey.astype(np.uint16) * 257),
    }[mode]
    out = io.BytesIO()
    image.save(out, format=fmt, **({"lossless": True} if fmt == "WEBP" else {}))
    mime = "image/webp" if fmt == "WEBP" else "image/png"
    scene = read_gltf(_with_image(exported_head, tmp_path / "g.glb", out.getvalue(), mime))
    assert scene.texture.shape == (32, 64, 3)
    assert abs(int(scene.texture[0, 63, 0]) - 255) <= 2 and scene.texture[0, 0, 0] <= 2
    assert (scene.texture[..., 0] == scene.texture[..., 2]).all()  # grey stays grey
