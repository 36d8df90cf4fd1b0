import numpy as np

from renderer.mosaic import mouth_box, pixelate


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
            cell = img[by:by + 8, bx:bx + 8].reshape(-1, 3)
            assert (cell == cell[0]).all()
            expected = before[by:by + 8, bx:bx + 8].reshape(-1, 3).mean(axis=0)
            assert np.abs(cell[0] - expected).max() <= 0.5 + 1e-9
    outside = np.ones((64, 64), bool)
    outside[8:40, 16:48] = False
    assert (img[outside] == before[outside]).all()
