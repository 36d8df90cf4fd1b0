"""The base colour of an avatar's materials as one texture the renderer samples per pixel.

Avatars made by other tools rarely have one material: a Ready Player Me head has one texture
each for skin, eyes, teeth, hair and clothes (nine in all), a VRoid export one per face part,
some with cut-outs (brows and eyelines drawn on alpha-masked cards). three.js samples each
material's texture per pixel; so does facepair, through one atlas:

- every image is decoded to RGBA (PNG and JPEG of any channel count, grey with alpha
  included; WebP, ``EXT_texture_webp``; KTX2, ``KHR_texture_basisu``: :func:`decode_image`);
- each (texture, alpha treatment) a primitive uses becomes a tile of the atlas, at most
  :data:`MAX_TILE` texels on its longer side (a face is drawn a few hundred pixels high), with
  a :data:`GUTTER` of repeated edge texels so that filtering and the coarser mipmap levels
  never reach a neighbour; a primitive without a texture samples a white tile;
- alpha (glTF 2.0 sec. 3.9.4) becomes a cut-out: ``OPAQUE`` materials are opaque whatever the
  image's alpha, ``MASK`` keeps the texels at or above ``alphaCutoff``, ``BLEND`` is drawn as a
  mask at half coverage (a face's blended parts, lashes and eyelines, are near-binary; sorting
  translucent triangles per frame would cost more than the rest of a frame on a CPU), which
  docs/reference/renderer.md states;
- UVs outside 0..1 (repeating textures) are wrapped per vertex into their tile.

Example
-------
>>> import numpy as np
>>> red, blue = np.zeros((4, 4, 4), np.uint8), np.zeros((2, 2, 4), np.uint8)
>>> red[..., 0] = red[..., 3] = 255; blue[..., 2] = blue[..., 3] = 255
>>> atlas = build_atlas([Tile(red, "OPAQUE", 0.5), Tile(blue, "OPAQUE", 0.5)])
>>> uv = atlas.place(1, np.array([[0.5, 0.5]]))
>>> h, w = atlas.image.shape[:2]
>>> atlas.image[int(uv[0, 1] * h), int(uv[0, 0] * w)].tolist()
[0, 0, 255, 255]
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field

import numpy as np

#: The longest side of one material's texture in the atlas (texels).
MAX_TILE = 1024
#: The longest side of a lone texture (one material: kept as it is up to this, as GL allows).
MAX_LONE = 4096
#: Texels of repeated edge around each tile: 2^3, the renderer's coarsest mipmap level.
GUTTER = 8
#: Coverage below which a BLEND texel is not drawn.
BLEND_CUTOFF = 0.5


def decode_image(data: bytes) -> np.ndarray:
    """Encoded image bytes as (h, w, 4) uint8 RGBA: KTX2 (Basis Universal) by its own
    transcoder, anything else by Pillow (PNG, JPEG, WebP; 8 or 16 bits; grey, grey with
    alpha, palette, RGB or RGBA). Raises ValueError when the bytes are no image."""
    if data[:5] == b"\xabKTX ":
        from renderer.gltfdecode import decode_ktx2

        return decode_ktx2(data)
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(io.BytesIO(data)) as image:
            image.load()
            if image.mode in ("I;16", "I;16B", "I"):  # 16-bit grey: keep its top 8 bits
                grey = (np.asarray(image, dtype=np.uint32) >> 8).astype(np.uint8)
                return np.dstack([grey, grey, grey, np.full_like(grey, 255)])
            return np.asarray(image.convert("RGBA"), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, SyntaxError) as exc:
        raise ValueError(f"not a readable image ({exc})") from None


@dataclass(frozen=True)
class Tile:
    """One material's texture: the RGBA image and how its alpha is drawn."""

    image: np.ndarray  # (h, w, 4) uint8
    alpha_mode: str = "OPAQUE"
    cutoff: float = 0.5

    def coverage(self) -> np.ndarray:
        """The image with its alpha made binary by the material's mode (255 drawn, 0 not)."""
        out = np.array(self.image, dtype=np.uint8)
        if self.alpha_mode == "OPAQUE":
            out[..., 3] = 255
        else:
            cut = self.cutoff if self.alpha_mode == "MASK" else BLEND_CUTOFF
            out[..., 3] = np.where(out[..., 3] >= cut * 255.0 - 1e-6, 255, 0)
        return out


@dataclass
class Atlas:
    """Tiles packed into one RGBA image; :meth:`place` maps a tile's UVs into it."""

    image: np.ndarray
    boxes: list[tuple[int, int, int, int]] = field(default_factory=list)  # x, y, w, h

    def place(self, tile: int, uv: np.ndarray) -> np.ndarray:
        """UVs of tile ``tile`` (0..1 over the tile; outside that, wrapped) in the atlas; a
        lone tile's UVs as they are (the texture repeats as its sampler says)."""
        x, y, w, h = self.boxes[tile]
        H, W = self.image.shape[:2]
        if len(self.boxes) == 1:
            return np.asarray(uv, dtype=np.float32)
        u = np.asarray(uv, dtype=np.float64)
        # wrapped per vertex into the tile: 1.0 stays the tile's far edge, not its near one
        wrapped = np.where((u >= 0.0) & (u <= 1.0), u, u % 1.0)
        return np.column_stack([(x + wrapped[:, 0] * w) / W, (y + wrapped[:, 1] * h) / H]).astype(
            np.float32
        )

    @property
    def cutout(self) -> bool:
        """Whether any texel is not drawn (a masked or blended material)."""
        return bool((self.image[..., 3] < 255).any())


def _scaled(image: np.ndarray, longest: int) -> np.ndarray:
    h, w = image.shape[:2]
    if max(h, w) <= longest:
        return image
    from PIL import Image

    k = longest / max(h, w)
    size = (max(1, round(w * k)), max(1, round(h * k)))
    return np.asarray(Image.fromarray(image, "RGBA").resize(size, Image.Resampling.BOX))


def build_atlas(tiles: list[Tile], *, max_tile: int = MAX_TILE, gutter: int = GUTTER) -> Atlas:
    """Pack ``tiles`` (scaled to at most ``max_tile`` texels) in rows into one image, each
    inside a gutter of its own edge texels; a single tile is kept as it is (up to
    :data:`MAX_LONE`)."""
    if len(tiles) == 1:
        lone = _scaled(tiles[0].coverage(), MAX_LONE)
        return Atlas(lone, [(0, 0, lone.shape[1], lone.shape[0])])
    images = [_scaled(t.coverage(), max_tile) for t in tiles]
    edge = ((gutter, gutter), (gutter, gutter), (0, 0))
    padded = [np.pad(im, edge, mode="edge") for im in images]
    order = sorted(range(len(padded)), key=lambda k: -padded[k].shape[0])
    width = max(
        max(p.shape[1] for p in padded),
        int(np.ceil(np.sqrt(sum(p.shape[0] * p.shape[1] for p in padded)))),
    )
    spots: dict[int, tuple[int, int]] = {}
    x = y = row = 0
    for k in order:
        h, w = padded[k].shape[:2]
        if x + w > width:
            x, y, row = 0, y + row, 0
        spots[k] = (x, y)
        x, row = x + w, max(row, h)
    image = np.full((y + row, width, 4), 255, np.uint8)  # between tiles: opaque white
    boxes = []
    for k, p in enumerate(padded):
        px, py = spots[k]
        image[py : py + p.shape[0], px : px + p.shape[1]] = p
        h, w = images[k].shape[:2]
        boxes.append((px + gutter, py + gutter, w, h))
    return Atlas(image, boxes)


WHITE = Tile(np.full((4, 4, 4), 255, np.uint8))
