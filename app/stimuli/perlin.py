"""One-dimensional Perlin (gradient) noise and its fractal octave sum, in numpy.

Thesis sec. 4.3.3, eq. 32: ``PerlinNoise(x) = sum_{i=0}^{octaves-1} persistence**i *
Noise(frequency_i * x)`` with ``frequency_i = 2**i``: each octave doubles the frequency and
its amplitude falls by the persistence. Eq. 33-34 feed it a frame-based input,
``x = (frame + frameOffset) * frequency / fps``, so the same frame always gets the same value
for a given seed and each channel with its own offset gets its own, uncorrelated trajectory.

``Noise`` is Perlin's gradient noise: every integer lattice point ``k`` gets a pseudo-random
gradient ``g_k`` in [-1, 1] (a counter-based hash of ``k``, the seed and the octave, so no
table repeats); between lattice points the two linear ramps ``g_k (x - k)`` and
``g_{k+1} (x - k - 1)`` are blended with Perlin's quintic fade ``6t^5 - 15t^4 + 10t^3``.
Hence ``Noise`` is 0 on the lattice and ``|Noise| <= 0.5``, and the octave sum is bounded by
:func:`fbm_bound`.

Example
-------
>>> x = np.array([0.0, 1.0, 2.0])
>>> bool(np.all(perlin_1d(x, seed=3) == 0))  # zero on the lattice
True
>>> bool(np.all(np.abs(fractal_noise(np.linspace(0, 50, 500), seed=1)) <= fbm_bound(6, 0.8)))
True
"""

from __future__ import annotations

import numpy as np

_MASK = 0xFFFFFFFFFFFFFFFF


def _hash_unit(k: np.ndarray, seed: int, octave: int) -> np.ndarray:
    """SplitMix64 of (lattice index, seed, octave) mapped to [-1, 1)."""
    z = k.astype(np.int64).astype(np.uint64) + np.uint64(
        (seed * 0x9E3779B97F4A7C15 + octave * 0xD1B54A32D192ED69) & _MASK
    )
    z = z * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) / float(1 << 52) - 1.0


def perlin_1d(x: np.ndarray, *, seed: int = 0, octave: int = 0) -> np.ndarray:
    """Perlin gradient noise at positions ``x`` (lattice spacing 1); values in [-0.5, 0.5]."""
    x = np.asarray(x, dtype=np.float64)
    k0 = np.floor(x)
    t = x - k0
    g0 = _hash_unit(k0, seed, octave)
    g1 = _hash_unit(k0 + 1, seed, octave)
    fade = t * t * t * (t * (t * 6 - 15) + 10)
    return (1 - fade) * g0 * t + fade * g1 * (t - 1)


def fractal_noise(
    x: np.ndarray, *, seed: int = 0, octaves: int = 6, persistence: float = 0.8
) -> np.ndarray:
    """Thesis eq. 32: ``sum_i persistence**i * perlin_1d(2**i * x)`` over ``octaves`` octaves."""
    x = np.asarray(x, dtype=np.float64)
    out = np.zeros_like(x)
    for i in range(int(octaves)):
        out += persistence**i * perlin_1d(x * 2.0**i, seed=seed, octave=i)
    return out


def fbm_bound(octaves: int = 6, persistence: float = 0.8) -> float:
    """Upper bound of ``|fractal_noise|``: ``0.5 * sum_i persistence**i``."""
    return 0.5 * sum(persistence**i for i in range(int(octaves)))


def frame_noise(
    n_frames: int,
    fps: float,
    *,
    frequency: float,
    frame_offset: int = 0,
    seed: int = 0,
    octaves: int = 6,
    persistence: float = 0.8,
) -> np.ndarray:
    """Thesis eq. 33-34: fractal noise of the frame number, ``x = (frame + offset) * f / fps``.

    ``frequency`` (Hz) is the lattice rate of the first octave; octave ``i`` runs at
    ``frequency * 2**i``, so keep ``frequency * 2**(octaves-1)`` below the Nyquist rate
    ``fps / 2`` or the top octave aliases.
    """
    frames = np.arange(int(n_frames), dtype=np.float64) + frame_offset
    return fractal_noise(
        frames * frequency / fps, seed=seed, octaves=octaves, persistence=persistence
    )
