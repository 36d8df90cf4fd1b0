"""The head's painted features: masks in 0..1, mirror-symmetric, each where it belongs."""

import numpy as np

from renderer.headmodel import MOUTH_HALF_WIDTH, MOUTH_Y
from renderer.skinpaint import (
    HAIR,
    LIPS,
    SKIN,
    brow_mask,
    cheek_mask,
    hair_mask,
    lip_mask,
    paint_skin,
)

RNG = np.random.default_rng(7)
POINTS = RNG.uniform([-90.0, -110.0, -90.0], [90.0, 110.0, 110.0], (4000, 3))


def test_masks_are_fractions_and_mirror_symmetric():
    mirrored = POINTS * [-1.0, 1.0, 1.0]
    for mask in (hair_mask, cheek_mask, brow_mask, lambda p: lip_mask(p, MOUTH_Y, 25.0)):
        values = mask(POINTS)
        assert values.min() >= 0.0 and values.max() <= 1.0
        np.testing.assert_allclose(values, mask(mirrored), atol=1e-12)


def test_each_feature_is_painted_where_it_lies():
    lips = np.array([[0.0, MOUTH_Y + 3.0, 90.0]])
    scalp = np.array([[0.0, 95.0, 20.0]])
    chin = np.array([[0.0, -95.0, 75.0]])
    colours = paint_skin(np.vstack([lips, scalp, chin]), MOUTH_Y, MOUTH_HALF_WIDTH)
    np.testing.assert_allclose(colours[0, :3], LIPS, atol=0.02)
    np.testing.assert_allclose(colours[1, :3], HAIR, atol=0.02)
    np.testing.assert_allclose(colours[2, :3], SKIN, atol=0.02)
    assert colours[0, 3] > colours[2, 3]  # the lips are glossier than the skin
