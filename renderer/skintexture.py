"""The built-in head's skin texture: a procedural albedo painted by numpy, no image fetched.

Parke's parameterised face (thesis sec. 2.1.2) separates the shape, given by a few
parameters, from the surface it is coloured with; per-vertex colour on an 11k-triangle mesh
can hold the large regions (lips, cheeks, hairline) but nothing finer than a vertex spacing
of 2-4 mm, so the skin read as plastic. This module paints the colour once into a texture the
renderer samples per pixel (one fetch; the lighting stays per vertex, see
:mod:`renderer.gl`):

* skin tone with low-frequency mottling and redness (cheeks, nose, lips), grain and pores
  at the scale of a pixel at 368 px (about 0.9 mm);
* a cavity term, darkening where the skin is concave (eye sockets, nasolabial folds,
  nostrils), baked into the albedo in place of normal detail;
* eyebrows as strands: a few hundred short curved hairs per brow, rooted in the brow's arch,
  rising at the inner end and sweeping outwards along it, drawn into a frontal map at
  0.1 mm per texel;
* hair on the skull as streaks.

The texture lies on the skin's ray grid (:func:`renderer.headparts.skin_grid`): column ``j``
and row ``i`` of the grid sit at texel ``((j + 0.5) / n_az, (i + 0.5) / (n_el + 2))``, so the
face, where the grid is dense, gets most of the texels; the band above the pole row is white,
for the parts that carry their own colour per vertex. Noise is drawn in millimetres on the
head (front and side projections blended by the normal), not in texels, so its scale is the
same everywhere. Deterministic for a seed.

Example
-------
>>> import numpy as np
>>> from renderer.headmodel import builtin_face
>>> face = builtin_face()
>>> face.texture.shape, face.texture.dtype.name
((1024, 1024, 3), 'uint8')
>>> bool((face.texture[-4] == 255).all())   # the white band
True
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

import renderer.skinpaint as paint
from renderer.sdf import smoothstep

#: Texels along each side of the texture.
TEXTURE_SIZE = 1024
#: Seed of the texture's noise: the same head every run.
TEXTURE_SEED = 20050607
#: Millimetres per texel of the noise maps projected on the head.
_NOISE_MM = 0.25


def grid_uvs(n_elevation: int, n_azimuth: int) -> np.ndarray:
    """(n_elevation * n_azimuth, 2) texture coordinates of the skin grid's vertices (row-major)."""
    i, j = np.meshgrid(np.arange(n_elevation), np.arange(n_azimuth), indexing="ij")
    return np.column_stack(
        [(j.ravel() + 0.5) / n_azimuth, (i.ravel() + 0.5) / (n_elevation + 2)]
    ).astype(np.float32)


def pole_uv(n_elevation: int) -> tuple[float, float]:
    """Texture coordinates of the grid's pole (the crown), in the row above the top row."""
    return 0.5, (n_elevation + 0.5) / (n_elevation + 2)


def white_uv(n_elevation: int) -> tuple[float, float]:
    """Texture coordinates inside the white band: parts coloured per vertex sample there."""
    return 0.5, (n_elevation + 1.5) / (n_elevation + 2)


def _texel_surface(grid: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Position and unit normal (size, size, 3) of the skin at each texel centre.

    Bilinear in the grid (n_el, n_az, 3), wrapping in azimuth; rows past the top row take it.
    """
    n_el, n_az, _ = grid.shape
    t = (np.arange(size) + 0.5) / size
    col = t * n_az - 0.5
    row = np.clip(t * (n_el + 2) - 0.5, 0, n_el - 1)
    c0 = np.floor(col).astype(int)
    fc = (col - c0)[None, :, None]
    r0 = np.minimum(np.floor(row).astype(int), n_el - 2)
    fr = (row - r0)[:, None, None]
    ca, cb = c0 % n_az, (c0 + 1) % n_az

    def at(a: np.ndarray) -> np.ndarray:
        top = a[r0][:, ca] * (1 - fc) + a[r0][:, cb] * fc
        bottom = a[r0 + 1][:, ca] * (1 - fc) + a[r0 + 1][:, cb] * fc
        return top * (1 - fr) + bottom * fr

    d_az = np.roll(grid, -1, axis=1) - np.roll(grid, 1, axis=1)
    d_el = np.gradient(grid, axis=0)
    normal = np.cross(d_az, d_el)
    normal /= np.maximum(np.linalg.norm(normal, axis=2, keepdims=True), 1e-9)
    n = at(normal)
    return at(grid), n / np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-9)


def _cavity(grid: np.ndarray, size: int) -> np.ndarray:
    """Concavity of the skin at each texel (mm of the grid's Laplacian into the surface).

    The umbrella Laplacian of the grid (mean of the four neighbours minus the vertex) along
    the outward normal: positive where the surface curves inwards.
    """
    lap = (
        np.roll(grid, 1, axis=1)
        + np.roll(grid, -1, axis=1)
        + np.vstack([grid[:1], grid[:-1]])
        + np.vstack([grid[1:], grid[-1:]])
    ) / 4 - grid
    d_az = np.roll(grid, -1, axis=1) - np.roll(grid, 1, axis=1)
    normal = np.cross(d_az, np.gradient(grid, axis=0))
    normal /= np.maximum(np.linalg.norm(normal, axis=2, keepdims=True), 1e-9)
    concave = np.einsum("ijk,ijk->ij", lap, normal)[..., None]
    return _texel_surface(np.concatenate([concave, concave, concave], axis=2), size)[0][..., 0]


def _noise_map(
    rng: np.random.Generator, shape: tuple[int, int], sigma: tuple[float, float]
) -> np.ndarray:
    """White noise low-passed by a Gaussian of ``sigma`` texels (rows, columns), unit std."""
    from scipy.ndimage import gaussian_filter

    m = gaussian_filter(rng.standard_normal(shape), sigma, mode="wrap")
    return m / max(float(m.std()), 1e-12)


def _pores(rng: np.random.Generator, shape: tuple[int, int], per_mm2: float) -> np.ndarray:
    """Small soft dots (0..1) scattered with ``per_mm2`` on a map of :data:`_NOISE_MM`."""
    from scipy.ndimage import gaussian_filter

    count = int(per_mm2 * shape[0] * shape[1] * _NOISE_MM**2)
    dots = np.zeros(shape)
    np.add.at(
        dots,
        (rng.integers(0, shape[0], count), rng.integers(0, shape[1], count)),
        rng.uniform(0.5, 1.0, count),
    )
    dots = gaussian_filter(dots, 1.1, mode="wrap")
    return np.clip(dots / max(float(np.percentile(dots, 99.5)), 1e-12), 0, 1)


class _Projected:
    """Maps in millimetres, sampled on the head by a front (x, y), a side (z, y) and a top
    (x, z) projection blended by the normal, so the pattern keeps its scale around the cheeks
    and over the crown (triplanar mapping). Without the top one, the crown, facing up, took
    the front and side maps edge-on: their patterns ran across it in lines, and a seam ran
    along its middle where the two met."""

    LO = np.array([-130.0, -140.0])  # x (or z) and y of the maps' first texel, mm

    def __init__(self, position: np.ndarray, normal: np.ndarray) -> None:
        self.front = (position[..., [1, 0]] - self.LO[::-1]) / _NOISE_MM
        self.side = (position[..., [1, 2]] - self.LO[::-1]) / _NOISE_MM
        self.top = (position[..., [2, 0]] - self.LO[[0, 0]]) / _NOISE_MM
        self.w_side = smoothstep(0.45, 0.85, np.abs(normal[..., 0]))
        self.w_top = smoothstep(0.55, 0.85, normal[..., 1])
        self.shape = (int(280 / _NOISE_MM), int(260 / _NOISE_MM))

    def sample(self, front: np.ndarray, side: np.ndarray, top: np.ndarray | None = None):
        """The maps at each texel (``top`` None: the front map serves on the crown too)."""
        from scipy.ndimage import map_coordinates

        a = map_coordinates(front, np.moveaxis(self.front, -1, 0), order=1, mode="grid-wrap")
        b = map_coordinates(side, np.moveaxis(self.side, -1, 0), order=1, mode="grid-wrap")
        out = a * (1 - self.w_side) + b * self.w_side
        if top is None:
            return out
        c = map_coordinates(top, np.moveaxis(self.top, -1, 0), order=1, mode="grid-wrap")
        return out * (1 - self.w_top) + c * self.w_top


#: Frontal map of the brows: x from :data:`_BROW_X0`, y from :data:`_BROW_Y0`, mm per texel.
_BROW_X0, _BROW_Y0, _BROW_MM = 6.0, 14.0, 0.1


def brow_strands(rng: np.random.Generator, n_hairs: int = 1100) -> np.ndarray:
    """Coverage (0..1) of one brow's hairs on a frontal map (rows up from y = 14 mm, columns
    out from x = 6 mm, 0.1 mm a texel); the other brow is its mirror image.

    Roots fill the brow's arch (:func:`renderer.skinpaint.brow_arch`); each hair is a short
    arc whose direction turns from rising (the inner end, the brow's head) to running outwards
    along the arch, tilted towards the arch's centre line, so the hairs meet along it as a
    real brow's do. Lengths 4-9 mm; the hairs thin towards their tips.
    """
    shape = (int(40 / _BROW_MM), int(62 / _BROW_MM))
    t = rng.beta(1.3, 1.6, n_hairs)  # more hairs at the head of the brow
    x = 13.0 + 40.0 * t
    centre, half = paint.brow_arch(x)
    across = rng.uniform(-1.0, 1.0, n_hairs)
    y = centre + 1.05 * half * across
    rise = np.radians(75.0) * smoothstep(0.35, 0.0, t)
    slope = np.arctan(np.gradient(centre, x) if n_hairs > 1 else 0.0)
    angle = (
        np.arctan2(np.sin(slope), np.cos(slope)) * (1 - smoothstep(0.35, 0.0, t))
        + rise
        - 0.45 * across * (1 - smoothstep(0.3, 0.0, t))
        + rng.normal(0.0, 0.12, n_hairs)
    )
    length = (4.0 + 5.0 * smoothstep(0.0, 0.5, t)) * rng.uniform(0.7, 1.1, n_hairs)
    curl = rng.normal(0.0, 0.06, n_hairs) - 0.04
    s = np.linspace(0.0, 1.0, int(12 / _BROW_MM))[None, :]
    heading = angle[:, None] + curl[:, None] * s * length[:, None]
    step = length[:, None] / s.shape[1]
    px = x[:, None] + np.cumsum(step * np.cos(heading), axis=1)
    py = y[:, None] + np.cumsum(step * np.sin(heading), axis=1)
    weight = (1.0 - 0.7 * s) * rng.uniform(0.6, 1.0, n_hairs)[:, None]
    cols = np.round((px - _BROW_X0) / _BROW_MM).astype(int).ravel()
    rows = np.round((py - _BROW_Y0) / _BROW_MM).astype(int).ravel()
    keep = (cols >= 0) & (cols < shape[1]) & (rows >= 0) & (rows < shape[0])
    density = np.zeros(shape)
    np.add.at(density, (rows[keep], cols[keep]), np.broadcast_to(weight, px.shape).ravel()[keep])
    from scipy.ndimage import gaussian_filter

    density = gaussian_filter(density, 1.2)
    return 1.0 - np.exp(-2.5 * density)


def skin_texture(
    grid: np.ndarray,
    mouth_y: float,
    half_width: float,
    *,
    size: int = TEXTURE_SIZE,
    seed: int = TEXTURE_SEED,
) -> np.ndarray:
    """The albedo (size, size, 3) uint8 of the skin grid ``grid`` (n_el, n_az, 3 positions).

    Parameters
    ----------
    grid : the skin's ray grid, rows of elevation by columns of azimuth (model mm).
    mouth_y, half_width : the mouth line and the half width of the lips, as for
        :func:`renderer.skinpaint.paint_skin`.
    size : texels per side; seed : the noise's seed (the same seed, the same texture).

    Returns
    -------
    uint8 (size, size, 3), display-referred like the per-vertex colours; row 0 is v = 0.
    """
    from scipy.ndimage import map_coordinates

    rng = np.random.default_rng(seed)
    n_el = grid.shape[0]
    pos, normal = _texel_surface(grid, size)
    flat = pos.reshape(-1, 3)
    proj = _Projected(pos, normal)
    shape = proj.shape

    # the top maps from their own stream, so the front and side maps stay as they were
    crown_rng = np.random.default_rng(seed + 1)

    def noise(sigma_mm: tuple[float, float]) -> np.ndarray:
        sigma = (sigma_mm[0] / _NOISE_MM, sigma_mm[1] / _NOISE_MM)
        top = _noise_map(crown_rng, shape, sigma)  # rows z, columns x: hair combed back
        return proj.sample(_noise_map(rng, shape, sigma), _noise_map(rng, shape, sigma), top)

    mottle, blotch = noise((5.0, 5.0)), noise((3.5, 3.5))
    grain = noise((0.45, 0.45))
    pores = proj.sample(_pores(rng, shape, 1.6), _pores(rng, shape, 1.6))
    streak = noise((5.0, 0.35))
    lip_lines = noise((1.2, 0.3))
    x, y, z = np.abs(pos[..., 0]), pos[..., 1], pos[..., 2]

    col = np.broadcast_to(paint.SKIN, pos.shape).copy()
    face = smoothstep(40.0, 70.0, z)
    # redness where the skin is thin or flushed: cheeks, nose tip and wings, chin, lids
    flush = (
        paint.cheek_mask(flat).reshape(x.shape)
        + 0.7 * np.exp(-((x / 14.0) ** 2 + ((y + 27.0) / 9.0) ** 2)) * face
        + 0.35 * np.exp(-((x / 16.0) ** 2 + ((y + 95.0) / 10.0) ** 2)) * face
    )
    col += 0.55 * np.clip(flush, 0, 1)[..., None] * (np.array([0.84, 0.49, 0.44]) - paint.SKIN)
    # darker, cooler skin under the eyes
    under = np.exp(-(((x - 30.0) / 11.0) ** 2 + ((y + 2.0) / 4.5) ** 2)) * face
    col *= 1.0 - 0.10 * under[..., None] * np.array([0.8, 1.0, 0.9])
    cavity = np.clip(_cavity(grid, size) / 1.4, 0.0, 1.0)
    detail = (
        (1.0 + 0.025 * mottle)
        * (1.0 + 0.025 * grain)
        * (1.0 - 0.3 * cavity)
        * (1.0 - 0.08 * pores * (0.5 + 0.5 * face))
    )
    detail /= detail[face > 0.5].mean()  # detail, not a darker skin: the tone stays SKIN's
    col *= detail[..., None]
    col += 0.1 * np.clip(blotch, 0, None)[..., None] * (np.array([0.84, 0.49, 0.44]) - paint.SKIN)
    # lips: the vermilion, with fine vertical lines and a darker line where they meet
    lip = paint.lip_mask(flat, mouth_y, half_width).reshape(x.shape)
    lips = paint.LIPS * (1.0 + 0.06 * lip_lines)[..., None] * (1.0 + 0.03 * grain)[..., None]
    meet = np.exp(-(((y - mouth_y) / 1.6) ** 2)) * smoothstep(half_width + 1, 0, x)
    lips *= 1.0 - 0.35 * meet[..., None]
    col += lip[..., None] * (lips - col)
    # eyebrows: a faint shade where they grow, the strands over it
    brow_area = paint.brow_mask(flat).reshape(x.shape)
    col += 0.35 * brow_area[..., None] * (paint.BROW - col)
    strands = brow_strands(rng)
    coords = np.stack([(y - _BROW_Y0) / _BROW_MM, (x - _BROW_X0) / _BROW_MM])
    hair = map_coordinates(strands, coords, order=1, mode="constant") * smoothstep(45, 60, z)
    brow_colour = paint.BROW * 0.8 * (1.0 + 0.1 * grain)[..., None]
    col += np.clip(hair, 0, 1)[..., None] * (brow_colour - col)
    scalp = paint.hair_mask(flat).reshape(x.shape)
    hair_colour = paint.HAIR * (1.0 + 0.35 * streak + 0.1 * grain)[..., None]
    col += scalp[..., None] * (hair_colour - col)

    out = np.clip(np.round(col * 255.0), 0, 255).astype(np.uint8)
    white_from = int(np.ceil((n_el + 1) / (n_el + 2) * size))
    out[white_from:] = 255
    return out


def cache_dir() -> Path:
    """Where painted textures are kept between processes: ``FACEPAIR_CACHE_DIR`` or the user's
    cache folder (``$XDG_CACHE_HOME/facepair``, else ``~/.cache/facepair``)."""
    explicit = os.environ.get("FACEPAIR_CACHE_DIR")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "facepair"


def cached_skin_texture(
    grid: np.ndarray,
    mouth_y: float,
    half_width: float,
    *,
    size: int = TEXTURE_SIZE,
    seed: int = TEXTURE_SEED,
    directory: Path | None = None,
) -> np.ndarray:
    """:func:`skin_texture`, painted once per machine: painting takes seconds (longer than a
    render job may stay silent), reading the stored texels milliseconds.

    The file name is a SHA-256 of the grid, the parameters and the source of the modules
    that paint (this one and :mod:`renderer.skinpaint`), so a changed head or painter never
    reads a stale texture. A cache folder that cannot be written is skipped, not an error.
    """
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(grid, dtype="<f8").tobytes())
    h.update(repr((float(mouth_y), float(half_width), int(size), int(seed))).encode())
    for module in (__file__, paint.__file__):
        h.update(Path(module).read_bytes())
    path = (directory or cache_dir()) / f"skin-{h.hexdigest()[:32]}.npy"
    try:
        texture = np.load(path, allow_pickle=False)
        if texture.shape == (size, size, 3) and texture.dtype == np.uint8:
            return texture
    except (OSError, ValueError):
        pass
    texture = skin_texture(grid, mouth_y, half_width, size=size, seed=seed)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        part = path.with_name(f"{path.name}.{os.getpid()}.part")
        with open(part, "wb") as fh:
            np.save(fh, texture, allow_pickle=False)
        os.replace(part, path)
    except OSError:
        pass
    return texture
