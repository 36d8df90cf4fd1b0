import numpy as np
import pytest

from app.stimuli.perlin import fbm_bound, fractal_noise, frame_noise, perlin_1d


def test_zero_on_the_lattice_and_bounded():
    lattice = np.arange(-50, 50, dtype=float)
    assert np.all(perlin_1d(lattice, seed=4) == 0)
    x = np.linspace(-50, 50, 100_001)
    n = perlin_1d(x, seed=4)
    assert np.abs(n).max() <= 0.5 and np.abs(n).max() > 0.3


@pytest.mark.parametrize("octaves,persistence", [(6, 0.8), (3, 0.5), (1, 1.0)])
def test_octave_sum_within_its_bound(octaves, persistence):
    x = np.linspace(0, 200, 200_001)
    f = fractal_noise(x, seed=9, octaves=octaves, persistence=persistence)
    assert np.abs(f).max() <= fbm_bound(octaves, persistence)
    assert fbm_bound(6, 0.8) == pytest.approx(0.5 * (1 - 0.8**6) / 0.2)


def test_octaves_add_detail_with_falling_amplitude():
    x = np.linspace(0, 100, 20_001)
    one = fractal_noise(x, seed=1, octaves=1)
    six = fractal_noise(x, seed=1, octaves=6)
    assert np.std(np.diff(six)) > 5 * np.std(np.diff(one))  # higher octaves: faster changes
    octave5 = six - fractal_noise(x, seed=1, octaves=5)
    np.testing.assert_allclose(octave5, 0.8**5 * perlin_1d(32 * x, seed=1, octave=5))


def test_deterministic_per_seed_and_frame_based():
    a = frame_noise(300, 30, frequency=0.3, seed=7)
    np.testing.assert_array_equal(a, frame_noise(300, 30, frequency=0.3, seed=7))
    assert not np.allclose(a, frame_noise(300, 30, frequency=0.3, seed=8))
    # the value is a function of the frame number: an offset window reads the same frames
    np.testing.assert_allclose(
        frame_noise(100, 30, frequency=0.3, seed=7, frame_offset=50), a[50:150]
    )
