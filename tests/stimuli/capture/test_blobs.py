import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from app.stimuli.capture.blobs import find_markers
from renderer.markers import MarkerLook, draw_marker_frame

NO_FACE = (np.zeros((0, 2)), np.zeros((0, 3), int))


def dots(centres, size=64, diameter=4.0, blur=0.6, noise=0.0, seed=0):
    """A dark frame with anti-aliased marker discs at sub-pixel ``centres``."""
    centres = np.asarray(centres, float)
    look = MarkerLook(blur_px=blur, noise=noise, seed=seed)
    return draw_marker_frame(
        centres, np.ones(len(centres), bool), np.full(len(centres), diameter), *NO_FACE, size, look
    )


def test_grey_centres_of_gravity_find_sub_pixel_positions():
    rng = np.random.default_rng(3)
    truth = np.column_stack([rng.uniform(8, 56, 6), np.linspace(8, 56, 6)])
    found = find_markers(dots(truth), 128)
    assert len(found) == 6
    np.testing.assert_allclose(found, truth, atol=0.1)
    # the binary map's centre (the thesis' likelier eq. 1-2) is quantised: worse, yet < 0.5 px
    binary = find_markers(dots(truth), 128, weights="binary")
    assert np.abs(found - truth).mean() < 0.5 * np.abs(binary - truth).mean()
    assert np.abs(binary - truth).max() < 0.5


def test_the_density_rule_rejects_specks_and_keeps_markers_in_noise():
    img = dots([[20.3, 30.7], [44.0, 12.5]], noise=6.0, seed=1)
    img[5, 5] = img[50, 50:53] = 255  # a hot pixel and a 3-pixel streak: density < 0.36
    found = find_markers(img, 128)
    np.testing.assert_allclose(found, [[44.0, 12.5], [20.3, 30.7]], atol=0.15)


def test_growth_stops_at_ten_pixels_and_dim_frames_have_no_markers():
    img = np.zeros((40, 40), np.uint8)
    img[5:25, 5:25] = 255  # a bright patch larger than any marker box
    found = find_markers(img, 128)
    assert len(found) >= 1 and np.all((found >= 5) & (found <= 25))
    assert len(find_markers(np.full((30, 30), 100, np.uint8), 128)) == 0
    with pytest.raises(ValueError, match="weights"):
        find_markers(img, 128, weights="mass")


@settings(max_examples=40, deadline=None)
@given(arrays(np.uint8, st.tuples(st.integers(1, 40), st.integers(1, 40))), st.floats(1, 255))
def test_any_frame_gives_centres_inside_it(img, threshold):
    found = find_markers(img, threshold)
    assert found.shape[1] == 2 and np.all(np.isfinite(found))
    assert np.all((found >= 0) & (found <= [img.shape[1], img.shape[0]]))
