"""Ears and neck of the built-in head, in pixels: shaped and textured ears seen at yaw 35,
a neck shaded under the jaw."""

import dataclasses

import numpy as np
import pytest
from scipy import ndimage

from renderer.deform import Rig
from renderer.gl import FaceCanvas
from renderer.headmodel import EAR_POSITION, builtin_face
from renderer.neckear import ear

pytestmark = pytest.mark.gl
SIZE = 368
DEG = np.radians(1.0) / 1e-5
BACKGROUND = (0.55, 0.56, 0.58)


def _draw(face, **faps):
    rig = Rig(face)
    f = np.zeros(68)
    for k, v in faps.items():
        f[int(k[1:]) - 1] = v
    canvas = FaceCanvas(rig, SIZE, background=BACKGROUND)
    try:
        return canvas.draw([rig.deform(f)]).copy().astype(float)
    finally:
        canvas.release()


def _right_ear_mask(face):
    """The right ear's pixels at yaw 35 (it faces the camera), its rim left out."""
    shell = ear(np.array([-1.0, 1.0, 1.0]) * EAR_POSITION, -1.0).vertices.astype(np.float32)
    as_rows = [("", np.float32)] * 3
    on_ear = np.isin(face.vertices.view(as_rows).ravel(), shell.view(as_rows).ravel())
    assert on_ear.sum() == len(shell)
    colors = face.colors.copy()
    colors[on_ear] = [0.0, 1.0, 0.0, 0.0]
    marked = _draw(dataclasses.replace(face, colors=colors, name="marked"), f49=35 * DEG)
    green = (marked[..., 1] > marked[..., 0] + 40) & (marked[..., 1] > marked[..., 2] + 40)
    return ndimage.binary_erosion(green, iterations=2)


def _detail(lum):
    """Luminance less its 3x3 mean: what a texture adds beyond the shading."""
    return lum - ndimage.uniform_filter(lum, 3)


def test_the_ear_is_shaped_and_carries_the_skin_texture():
    textured, plain = builtin_face("textured"), builtin_face("plain")
    mask = _right_ear_mask(textured)
    assert mask.sum() > 300  # seen at yaw 35
    lum = {k: _draw(f, f49=35 * DEG).mean(axis=2) for k, f in (("t", textured), ("p", plain))}
    # shaped: the concha's bowl in shade against the lit rim (a flat plate was one tone)
    inside = lum["t"][mask]
    assert np.percentile(inside, 90) - np.percentile(inside, 10) > 25
    # textured: finer detail than the same ear in per-vertex colour
    assert _detail(lum["t"])[mask].std() > 1.5 * _detail(lum["p"])[mask].std()


def test_the_neck_is_in_the_chins_shadow_under_the_jaw():
    # down the midline of the front view, from the jaw's outline (the darkest row under the
    # mouth) the neck brightens out of the chin's shadow; the cylinder was one tone
    lum = _draw(builtin_face()).mean(axis=2)[:, SIZE // 2]
    jaw_line = int(SIZE * 0.78) + int(np.argmin(lum[int(SIZE * 0.78) : int(SIZE * 0.88)]))
    under, lower = lum[jaw_line + 4 : jaw_line + 10].mean(), lum[jaw_line + 40 : jaw_line + 46]
    assert jaw_line + 46 < SIZE and lower.mean() - under > 15
