"""The built-in head's painted features: where the lips, eyebrows, cheeks and hair lie.

Each mask is a smooth 0..1 field over points of the head (model millimetres, as in
:mod:`renderer.headmodel`): the lips' vermilion with a cupid's bow (:func:`lip_mask`), the
eyebrows' arch (:func:`brow_arch`, :func:`brow_mask`), the cheeks' flush
(:func:`cheek_mask`) and the hairline (:func:`hair_mask`). :func:`paint_skin` colours the
skin's vertices with them (the ``plain`` look); :mod:`renderer.skintexture` paints the same
masks, with pores and strands, into the ``textured`` look's texture, and the head's shape
takes its hair volume from :func:`hair_mask`.
"""

from __future__ import annotations

import numpy as np

from renderer.sdf import smoothstep

SKIN = np.array([0.80, 0.60, 0.50])
LIPS = np.array([0.66, 0.34, 0.34])
HAIR = np.array([0.20, 0.14, 0.10])
BROW = np.array([0.26, 0.18, 0.13])


def hair_mask(p: np.ndarray) -> np.ndarray:
    """1 where hair grows on the skull (hairline by azimuth about the head's vertical axis)."""
    az = np.degrees(np.abs(np.arctan2(p[:, 0], p[:, 2] + 5.0)))
    line = np.interp(az, [0, 30, 50, 72, 85, 110, 140, 180], [76, 70, 52, 30, 40, 5, -40, -48])
    return smoothstep(line - 4.0, line + 7.0, p[:, 1])


def cheek_mask(p: np.ndarray) -> np.ndarray:
    """0..1 where the cheeks flush, on the front of the face."""
    x, y, z = np.abs(p[:, 0]), p[:, 1], p[:, 2]
    return np.exp(-(((x - 40) / 18) ** 2 + ((y + 25) / 16) ** 2)) * smoothstep(40, 60, z)


def lip_mask(p: np.ndarray, mouth_y: float, half_width: float) -> np.ndarray:
    """0..1 on the vermilion: upper lip with a cupid's bow, fuller lower lip."""
    x, y, z = np.abs(p[:, 0]), p[:, 1], p[:, 2]
    prof = np.sqrt(np.clip(1 - (x / half_width) ** 2, 0, 1))
    upper = mouth_y + 8.0 * prof**0.7 - 1.6 * np.exp(-((x / 4.0) ** 2)) + 0.6
    lower = mouth_y - 10.0 * np.sqrt(np.clip(1 - (x / (half_width - 1)) ** 2, 0, 1)) ** 0.8
    lip = smoothstep(upper + 1.0, upper - 1.0, y) * smoothstep(lower - 1.0, lower + 1.0, y)
    return lip * smoothstep(70, 80, z) * smoothstep(half_width + 0.5, half_width - 2.0, x)


def brow_arch(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre height and half height (mm) of the eyebrow's arch at ``|x|``: from beside the
    nose bridge (x = 13) to the temple (x = 53)."""
    t = (x - 13.0) / 40.0
    centre = 29.0 + 6.5 * np.sin(np.pi * np.clip(t, 0, 1) * 0.85) - 2.5 * t
    return centre, 3.6 * (1 - t) + 1.6 * t


def brow_mask(p: np.ndarray) -> np.ndarray:
    """0..1 over the eyebrows (:func:`brow_arch`), on the front of the face."""
    x, y, z = np.abs(p[:, 0]), p[:, 1], p[:, 2]
    t = (x - 13.0) / 40.0
    centre, half = brow_arch(x)
    return (
        smoothstep(half + 1.8, half - 1.2, np.abs(y - centre))
        * smoothstep(-0.05, 0.05, t)
        * smoothstep(1.05, 0.9, t)
        * smoothstep(45, 60, z)
    )


def paint_skin(p: np.ndarray, mouth_y: float, half_width: float) -> np.ndarray:
    """Skin colour with lips, eyebrows, cheeks and hair painted on (RGB + specular)."""
    col = np.tile(SKIN, (len(p), 1))
    col = col + 0.5 * cheek_mask(p)[:, None] * (np.array([0.84, 0.50, 0.45]) - SKIN)
    lip = lip_mask(p, mouth_y, half_width)
    col = col + lip[:, None] * (LIPS - col)
    col = col + 0.92 * brow_mask(p)[:, None] * (BROW - col)
    col = col + hair_mask(p)[:, None] * (HAIR - col)
    spec = 0.18 + 0.15 * lip
    return np.column_stack([col, spec])
