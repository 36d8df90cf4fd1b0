"""The look of a glTF primitive, PBR-lite: display colour and specular strength per vertex,
and the base colour texture sampled per pixel.

Base colours come from ``COLOR_0`` and ``baseColorFactor`` per vertex (glTF's factors are
linear; the renderer's colours display-referred, its shader squares them) and from the
``baseColor`` textures per pixel, every material's in one atlas with its alpha mode
(:mod:`renderer.gltftexture`); the specular strength from the material's roughness and
metalness, or from the renderer's own attribute :data:`SPECULAR_ATTRIBUTE` where
:mod:`renderer.gltfwrite` wrote it. A texture's image is its KTX2 or WebP source
(:mod:`renderer.gltfdecode`) or its PNG / JPEG, from the binary chunk, a data URI or a file
beside the glTF (Khronos, glTF 2.0 sec. 3.8-3.9).
"""

from __future__ import annotations

import base64
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from renderer.gltfaccessor import read_accessor
from renderer.gltfdecode import texture_source, texture_transform
from renderer.gltftexture import WHITE, Tile, build_atlas, decode_image

#: Specular strength of a fully smooth dielectric (the renderer's 4th colour column).
SPECULAR_SMOOTH = 0.5
#: Application-specific vertex attribute carrying the renderer's specular strength.
SPECULAR_ATTRIBUTE = "_SPECULAR"


def _image_bytes(gltf, blob: bytes, index: int, base: Path) -> bytes | None:
    image = gltf.images[index]
    if image.bufferView is not None:
        view = gltf.bufferViews[image.bufferView]
        return blob[view.byteOffset or 0 : (view.byteOffset or 0) + view.byteLength]
    if image.uri and image.uri.startswith("data:"):
        return base64.b64decode(image.uri.split(",", 1)[1])
    if image.uri:
        target = (base / image.uri).resolve()
        if not target.is_file() or base.resolve() not in target.parents:
            raise ValueError(f"{image.uri} is not a file beside the glTF")
        return target.read_bytes()
    return None


def _texture_rgba(gltf, blob: bytes, texture_index: int, path: Path) -> np.ndarray | None:
    """The base colour image of texture ``texture_index`` as (h, w, 4) uint8 RGBA, or None
    when the texture names no image. Its KTX2 (``KHR_texture_basisu``) or WebP
    (``EXT_texture_webp``) source first, then its own ``source`` (the PNG or JPEG fallback such
    files may carry); an image that names data it cannot decode is refused by name."""
    try:
        sources = [
            i
            for i in dict.fromkeys(
                (texture_source(gltf, texture_index), _plain_source(gltf, texture_index))
            )
            if i is not None
        ]
    except (IndexError, TypeError, AttributeError):
        return None
    problem = ""
    for index in sources:
        try:
            data = _image_bytes(gltf, blob, index, path.parent)
            if data is not None:
                return decode_image(data)
        except (ValueError, IndexError, TypeError, AttributeError, OSError) as exc:
            problem = f"image {index} cannot be read: {str(exc).splitlines()[0][:100]}"
    if problem:
        raise InputError(f"texture {texture_index}: {problem}", path=path)
    return None


def _plain_source(gltf, texture_index: int) -> int | None:
    try:
        return gltf.textures[texture_index].source
    except (IndexError, TypeError):
        return None


#: A primitive's base colour texture: (texture index, alpha mode, cutoff), its UVs and image.
TextureUse = tuple[tuple[int, str, float], np.ndarray, np.ndarray]


def primitive_colors(
    gltf, blob: bytes, prim, n: int, path: Path
) -> tuple[np.ndarray, TextureUse | None]:
    """Per-vertex display RGB and specular strength of a primitive (PBR-lite), without its
    texture, and the texture it samples (see :data:`TextureUse`), if any."""
    out = np.ones((n, 4))
    texture = None
    out[:, 3] = 0.18
    mat = gltf.materials[prim.material] if prim.material is not None else None
    pbr = mat.pbrMetallicRoughness if mat is not None else None
    if pbr is not None:
        # glTF factors are linear; the renderer's colours display-referred (its shader squares)
        out[:, :3] *= np.sqrt(np.clip(np.array(pbr.baseColorFactor or [1, 1, 1, 1])[:3], 0, 1))
        rough = 1.0 if pbr.roughnessFactor is None else pbr.roughnessFactor
        metal = 1.0 if pbr.metallicFactor is None else pbr.metallicFactor
        out[:, 3] = SPECULAR_SMOOTH * (1.0 - rough) * (1.0 - 0.5 * metal)
        info = pbr.baseColorTexture
        uv_name = f"TEXCOORD_{info.texCoord or 0}" if info is not None else None
        uv_index = getattr(prim.attributes, uv_name, None) if uv_name else None
        if info is not None and uv_index is not None:
            rgba = _texture_rgba(gltf, blob, info.index, path)
            if rgba is not None:
                uv = texture_transform(info, read_accessor(gltf, blob, uv_index, path)[:, :2])
                mode = str(getattr(mat, "alphaMode", None) or "OPAQUE")
                cut = getattr(mat, "alphaCutoff", None)
                cutoff = 0.5 if cut is None else float(cut)
                texture = ((int(info.index), mode, cutoff), uv, rgba)
    if prim.attributes.COLOR_0 is not None:
        c = read_accessor(gltf, blob, prim.attributes.COLOR_0, path)
        out[:, :3] *= np.sqrt(np.clip(c[:, :3], 0, 1))
    spec = getattr(prim.attributes, SPECULAR_ATTRIBUTE, None)
    if spec is not None:
        out[:, 3] = read_accessor(gltf, blob, spec, path)[:, 0]
    return out, texture


def texture_atlas(
    parts: list[dict[str, Any]], colors: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every primitive's base colour texture in one atlas the renderer samples per pixel
    (:mod:`renderer.gltftexture`): the (n, 2) float32 UVs into it, its image (RGBA only when
    some texels are cut out) and ``colors`` (the scene's, in primitive order) times each
    vertex's texel, for what reads colours per vertex."""
    keys: dict[tuple[int, str, float], int] = {}
    tiles: list[Tile] = []
    for p in parts:
        if p["texture"] is not None and p["texture"][0] not in keys:
            key, _, image = p["texture"]
            keys[key] = len(tiles)
            tiles.append(Tile(image, key[1], key[2]))
    if any(p["texture"] is None for p in parts):
        tiles.append(WHITE)
    atlas = build_atlas(tiles)
    placed = []
    for p in parts:
        if p["texture"] is None:
            placed.append(atlas.place(len(tiles) - 1, np.full((len(p["pos"]), 2), 0.5)))
        else:
            placed.append(atlas.place(keys[p["texture"][0]], p["texture"][1]))
    uvs = np.vstack(placed).astype(np.float32)
    texture = atlas.image if atlas.cutout else np.ascontiguousarray(atlas.image[..., :3])
    h, w = atlas.image.shape[:2]
    rows = np.clip((uvs[:, 1] * h).astype(int), 0, h - 1)
    cols = np.clip((uvs[:, 0] * w).astype(int), 0, w - 1)
    baked = colors.copy()
    baked[:, :3] *= atlas.image[rows, cols, :3] / 255.0
    return uvs, texture, baked
