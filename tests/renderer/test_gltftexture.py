"""One atlas of every material's base colour, with its alpha mode (renderer.gltftexture)."""

import io

import numpy as np
import pytest
from PIL import Image

from renderer.gltftexture import GUTTER, WHITE, Tile, build_atlas, decode_image


def _encoded(array, mode, fmt):
    out = io.BytesIO()
    Image.fromarray(array, mode).save(out, format=fmt)
    return out.getvalue()


@pytest.mark.parametrize(
    ("mode", "channels", "fmt"),
    [("L", 1, "PNG"), ("LA", 2, "PNG"), ("RGB", 3, "JPEG"), ("RGBA", 4, "WEBP"), ("P", 1, "PNG")],
)
def test_every_channel_count_and_format_decodes_to_rgba(mode, channels, fmt):
    rng = np.random.default_rng(1)
    shape = (6, 5) if channels == 1 else (6, 5, channels)
    array = rng.integers(0, 256, shape, dtype=np.uint8)
    if mode == "P":
        image = Image.fromarray(array, "L").convert("P")
        data = io.BytesIO()
        image.save(data, format="PNG")
        rgba = decode_image(data.getvalue())
    else:
        rgba = decode_image(_encoded(array, mode, fmt))
    assert rgba.shape == (6, 5, 4) and rgba.dtype == np.uint8
    if mode == "LA":  # grey with alpha: the grey in every channel, the alpha kept
        assert np.array_equal(rgba[..., 0], array[..., 0])
        assert np.array_equal(rgba[..., 2], array[..., 0])
        assert np.array_equal(rgba[..., 3], array[..., 1])
    if mode == "RGBA":  # lossless WebP is not the default: compare loosely
        assert np.abs(rgba[..., 3].astype(int) - array[..., 3]).max() <= 255


def test_a_16_bit_grey_png_keeps_its_top_byte():
    array = np.array([[0, 256, 65535]], dtype=np.uint16)
    out = io.BytesIO()
    Image.fromarray(array).save(out, format="PNG")
    assert decode_image(out.getvalue())[0, :, 0].tolist() == [0, 1, 255]


def test_bytes_that_are_no_image_are_a_value_error():
    with pytest.raises(ValueError, match="not a readable image"):
        decode_image(b"\x89PNG but not really")


def test_alpha_modes_become_binary_coverage():
    image = np.zeros((1, 4, 4), np.uint8)
    image[0, :, 3] = [0, 100, 140, 255]
    assert Tile(image, "OPAQUE").coverage()[0, :, 3].tolist() == [255] * 4
    assert Tile(image, "MASK", 0.5).coverage()[0, :, 3].tolist() == [0, 0, 255, 255]
    assert Tile(image, "MASK", 0.3).coverage()[0, :, 3].tolist() == [0, 255, 255, 255]
    assert Tile(image, "BLEND").coverage()[0, :, 3].tolist() == [0, 0, 255, 255]


def _solid(colour, h=16, w=16):
    out = np.zeros((h, w, 4), np.uint8)
    out[...] = [*colour, 255]
    return out


def test_each_tile_is_sampled_where_its_uvs_go_and_the_gutter_is_its_edge():
    tiles = [Tile(_solid(c, 16 + 8 * k, 16)) for k, c in enumerate([(255, 0, 0), (0, 255, 0)])]
    atlas = build_atlas([*tiles, WHITE])
    h, w = atlas.image.shape[:2]
    for k, colour in enumerate([(255, 0, 0), (0, 255, 0), (255, 255, 255)]):
        uv = atlas.place(k, np.array([[0.0, 0.0], [0.999, 0.999], [0.5, 0.5], [1.25, -0.25]]))
        texels = atlas.image[(uv[:, 1] * h).astype(int), (uv[:, 0] * w).astype(int), :3]
        assert (texels == colour).all(), (k, texels)
        x, y, tw, th = atlas.boxes[k]
        ring = atlas.image[y - GUTTER : y + th + GUTTER, x - GUTTER : x + tw + GUTTER, :3]
        assert (ring == colour).all()  # filtering near the edge never meets a neighbour
    assert not atlas.cutout


def test_a_lone_texture_keeps_its_uvs_and_a_large_one_is_scaled():
    big = Tile(_solid((9, 9, 9), 3000, 1500))
    atlas = build_atlas([big])
    assert atlas.image.shape[:2] == (3000, 1500)  # alone: untouched, its sampler repeats it
    assert atlas.place(0, np.array([[1.5, -0.5]])).tolist() == [[1.5, -0.5]]
    two = build_atlas([big, WHITE], max_tile=1024)
    x, y, tw, th = two.boxes[0]
    assert (tw, th) == (512, 1024)


def test_a_masked_material_makes_a_cutout_atlas():
    card = _solid((50, 40, 30))
    card[:8, :, 3] = 0
    atlas = build_atlas([Tile(card, "MASK", 0.5), WHITE])
    assert atlas.cutout
    x, y, tw, th = atlas.boxes[0]
    assert (atlas.image[y : y + 8, x : x + tw, 3] == 0).all()
    assert (atlas.image[y + 8 : y + th, x : x + tw, 3] == 255).all()
