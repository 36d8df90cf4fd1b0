import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from renderer.mosaic import mouth_box, pixelate, pixelate_reference


def test_box_snaps_outwards_to_whole_blocks():
    pts = np.array([[33.0, 41.0], [70.0, 55.0]])
    x0, y0, x1, y1 = mouth_box(pts, 200, 200, block=16, margin=0.0)
    assert (x0, y0, x1, y1) == (32, 32, 80, 64)
    assert x0 <= 33 and x1 >= 70 and y0 <= 41 and y1 >= 55


def test_margin_grows_the_box_by_a_fraction_of_its_larger_side():
    pts = np.array([[100.0, 100.0], [140.0, 110.0]])
    x0, y0, x1, y1 = mouth_box(pts, 300, 300, block=4, margin=0.25)  # grow by 10 px
    assert (x0, y0, x1, y1) == (88, 88, 152, 120)


def test_box_is_clipped_to_the_image_and_stays_whole_blocks():
    pts = np.array([[-5.0, 90.0], [50.0, 130.0]])
    x0, y0, x1, y1 = mouth_box(pts, 100, 100, block=16, margin=0.0)
    assert x0 == 0 and y1 <= 100
    assert (x1 - x0) % 16 == 0 and (y1 - y0) % 16 == 0


def test_pixelate_makes_each_block_its_mean_colour():
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (64, 64, 3), dtype=np.uint8)
    before = img.copy()
    pixelate(img, (16, 8, 48, 40), 8)
    for by in range(8, 40, 8):
        for bx in range(16, 48, 8):
            cell = img[by : by + 8, bx : bx + 8].reshape(-1, 3)
            assert (cell == cell[0]).all()
            expected = before[by : by + 8, bx : bx + 8].reshape(-1, 3).mean(axis=0)
            assert np.abs(cell[0] - expected).max() <= 0.5 + 1e-9
    outside = np.ones((64, 64), bool)
    outside[8:40, 16:48] = False
    assert (img[outside] == before[outside]).all()


def _reference_mosaic_by_cells(image, reference, box, block, background):
    """pixelate_reference's definition, one cell at a time."""
    out = image.copy()
    x0, y0, x1, y1 = box
    for by in range(y0, y1, block):
        for bx in range(x0, x1, block):
            ref = reference[by - y0 : by - y0 + block, bx - x0 : bx - x0 + block].reshape(-1, 3)
            own = image[by : by + block, bx : bx + block].reshape(-1, 3)
            on_ref = (ref != background).any(axis=1)
            on_own = (own != background).any(axis=1)
            source = ref[on_ref] if on_ref.any() else own[on_own]
            if not len(source):
                continue
            mean = np.floor(source.astype(float).mean(axis=0) + 0.5).astype(np.uint8)
            cell = out[by : by + block, bx : bx + block]
            cell[(cell != background).any(axis=2)] = mean
    return out


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    block=st.sampled_from([1, 2, 4, 8, 24]),
    cells=st.tuples(st.integers(0, 4), st.integers(0, 4)),
    share=st.floats(0.0, 1.0),
)
def test_pixelate_reference_is_the_mean_face_colour_of_the_reference_per_cell(
    seed, block, cells, share
):
    rng = np.random.default_rng(seed)
    background = np.array([140, 143, 148], np.uint8)
    image = rng.integers(0, 256, (130, 150, 3), dtype=np.uint8)
    image[rng.random((130, 150)) > share] = background  # background inside and around the face
    x0, y0 = int(rng.integers(0, 20)), int(rng.integers(0, 20))
    box = (x0, y0, x0 + cells[0] * block, y0 + cells[1] * block)
    reference = rng.integers(0, 256, (cells[1] * block, cells[0] * block, 3), dtype=np.uint8)
    reference[rng.random(reference.shape[:2]) > share] = background
    reference[:block] = background  # a row of cells with no reference face pixel
    expected = _reference_mosaic_by_cells(image, reference, box, block, background)
    assert np.array_equal(pixelate_reference(image, reference, box, block, background), expected)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    block=st.sampled_from([4, 8, 16]),
    pad=st.sampled_from([0.0, 2.0]),
)
def test_cells_meeting_misses_no_cell_the_polygon_reaches(seed, block, pad):
    from renderer.mosaic import cells_meeting

    rng = np.random.default_rng(seed)
    polygon = rng.uniform(0, 96, (int(rng.integers(3, 12)), 2))
    box = (0, 0, 96, 96)
    cells = cells_meeting(polygon, box, block, pad)
    # a dense sampling of the polygon (convex combinations of its corners), grown by pad
    w = rng.dirichlet(np.ones(len(polygon)), 4000)
    inside = w @ polygon
    for dx, dy in ((0, 0), (pad, 0), (-pad, 0), (0, pad), (0, -pad)):
        p = np.clip(inside + [dx, dy], 0, 95.999)
        assert cells[(p[:, 1] // block).astype(int), (p[:, 0] // block).astype(int)].all()
    # and nothing far from it
    lo, hi = polygon.min(axis=0) - pad - block, polygon.max(axis=0) + pad + block
    ys, xs = np.nonzero(cells)
    assert (xs * block >= lo[0] - block).all() and ((xs + 1) * block <= hi[0] + block).all()
    assert (ys * block >= lo[1] - block).all() and ((ys + 1) * block <= hi[1] + block).all()
