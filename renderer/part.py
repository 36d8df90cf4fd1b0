"""A part of the built-in head's mesh, and how parts are merged into one.

The head (:mod:`renderer.headmodel`) is built from parts: the skin's ray grid, eyeballs,
eyelids, ears, the mouth, the neck (:mod:`renderer.headparts`, :mod:`renderer.mouthparts`,
:mod:`renderer.neckear`), each with its own vertices, triangles and colours, its vertex groups
(``fp:<name>`` marks an MPEG-4 feature point, :mod:`renderer.face`) and the weight layers that
the deformation reads. :func:`merge` concatenates them into the one mesh that is drawn.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

LAYER_DEFAULTS = {"head": 1.0}


@dataclass
class Part:
    """Vertices, triangles, RGB + specular colours, vertex groups and per-vertex weight layers
    (``head``, ``jaw``, ``upper_lip``, ``lower_lip``, ``eyelid_*``) of one part of the head."""

    vertices: np.ndarray
    triangles: np.ndarray
    colors: np.ndarray
    groups: dict[str, np.ndarray] = field(default_factory=dict)
    layers: dict[str, np.ndarray] = field(default_factory=dict)
    uvs: np.ndarray | None = None  # (n, 2) texture coordinates, if the part is textured


def merge(parts: list[Part], default_uv: tuple[float, float] | None = None) -> Part:
    """Concatenate parts, offsetting indices; missing layers get their default (head 1, else 0).

    With ``default_uv``, the merged part has texture coordinates: each part's own, or
    ``default_uv`` on a part without them.
    """
    offsets = np.cumsum([0] + [len(p.vertices) for p in parts])
    names = sorted({k for p in parts for k in p.layers})
    layers = {
        k: np.concatenate(
            [p.layers.get(k, np.full(len(p.vertices), LAYER_DEFAULTS.get(k, 0.0))) for p in parts]
        )
        for k in names
    }
    groups: dict[str, list[np.ndarray]] = {}
    for off, p in zip(offsets, parts, strict=False):
        for k, idx in p.groups.items():
            groups.setdefault(k, []).append(np.asarray(idx) + off)
    return Part(
        vertices=np.concatenate([p.vertices for p in parts]),
        triangles=np.concatenate(
            [p.triangles + off for off, p in zip(offsets, parts, strict=False)]
        ),
        colors=np.concatenate([p.colors for p in parts]),
        groups={k: np.concatenate(v).astype(np.int64) for k, v in groups.items()},
        layers=layers,
        uvs=None
        if default_uv is None
        else np.concatenate(
            [
                p.uvs
                if p.uvs is not None
                else np.tile(np.asarray(default_uv, np.float32), (len(p.vertices), 1))
                for p in parts
            ]
        ).astype(np.float32),
    )
