"""The zones of the translational FAPs: how far each lip, chin and brow FAP moves each vertex.

Follows the MPEG-4 FBA deformation as the open player Xface implements it (project reference
``mpeg4-fap``): a vertex at distance ``d`` from a FAP's feature point moves by
``w(d) * value * FAPU`` along the FAP's direction, with the raised-cosine influence
``w(d) = (1 + cos(pi d / dmax)) / 2`` for ``d < dmax``. Each FAP's feature point, direction,
FAPU and side are read from the FAP table (:mod:`app.stimuli.fap`). The zones:

* lips, inner (4-13) and outer (51-60), push (16, 17) and chin (18), with the upper- and
  lower-lip FAPs kept to their own lip (Parke's unconnected lips, thesis sec. 2.1.2);
* eyebrows, raise (31-36) and squeeze (37/38). The brows use a smooth field separable in width
  and height (:func:`renderer.browfield.brow_field`) instead of radial zones, and a lowered
  brow saturates before the skin between brow and lid would fold.

Zones along one lip or brow reach exactly to the neighbouring feature point, so each feature
point moves by value * FAPU and equal values move the lip or brow uniformly; an inner/outer lip
pair shares a vertex by proximity (the nearer feature point wins). :func:`translation_basis`
gives every zone as a displacement per unit FAP value; :class:`renderer.deform.Rig` moves the
face by their sum.
"""

from __future__ import annotations

import numpy as np

from app.stimuli.fap import (
    DIRECTION,
    EYEBROW_RAISE,
    EYEBROW_SQUEEZE,
    EYELIDS,
    FAPS,
    FEATURE_POINT,
    INNER_LIPS,
    LIP_PUSH_CHIN,
    OUTER_LIPS,
    SIDE,
)
from renderer.browfield import BROW_LOWER_ROOM, BROW_RAMP_END, brow_field
from renderer.face import Face

#: Outer lip FAP of each inner one, and outer lip feature point of each inner one.
_OUTER_FAP = dict(zip(INNER_LIPS, OUTER_LIPS, strict=True))
_OUTER_OF = {FEATURE_POINT[i]: FEATURE_POINT[o] for i, o in _OUTER_FAP.items()}
#: Lip zones whose weights are normalised together (vertical motion of one lip): the feature
#: points along each inner lip, corners included.
_CHAINS = {
    "upper": ("2.2", "2.6", "2.7", "2.4", "2.5"),
    "lower": ("2.3", "2.8", "2.9", "2.4", "2.5"),
}


def direction(fap: int) -> np.ndarray:
    """The unit vector a positive value of translational ``fap`` moves its feature point."""
    return np.array(DIRECTION[fap])


def on_side(faps: tuple[int, ...], side: str) -> tuple[int, ...]:
    """The FAPs of ``faps`` on ``side`` (``"l"`` or ``"r"``) of the face, in their order."""
    return tuple(f for f in faps if SIDE.get(f) == side)


def raised_cosine(d: np.ndarray, dmax: float) -> np.ndarray:
    """Xface's influence ``(1 + cos(pi d / dmax)) / 2`` inside ``dmax``, 0 outside."""
    return np.where(d < dmax, 0.5 * (1.0 + np.cos(np.pi * np.minimum(d / dmax, 1.0))), 0.0)


def _chain_weights(v: np.ndarray, points: list[np.ndarray]) -> np.ndarray:
    """Raised-cosine zones along a chain of feature points (a lip, a brow), (k, n).

    Each zone reaches exactly to the nearest other point of the chain, so a feature point
    moves by its own FAP alone (weight 1) and, between two points, the two zones sum to one
    (cos^2 + sin^2): equal values move the chain uniformly.
    """
    pts = np.asarray(points, dtype=np.float64)
    gaps = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    np.fill_diagonal(gaps, np.inf)
    reach = np.maximum(gaps.min(axis=1), 1e-6)
    return np.stack(
        [raised_cosine(np.linalg.norm(v - p, axis=1), r) for p, r in zip(pts, reach, strict=True)]
    )


def _pair_share(v: np.ndarray, fp: dict[str, np.ndarray], inner_pt: str, tag: str) -> np.ndarray:
    """Share of an inner or outer lip FAP at each vertex: the nearer feature point wins."""
    d_in = np.linalg.norm(v - fp[inner_pt], axis=1)
    d_out = np.linalg.norm(v - fp[_OUTER_OF[inner_pt]], axis=1)
    total = np.maximum(d_in + d_out, 1e-9)
    return d_out / total if tag == "inner" else d_in / total


def translation_basis(
    face: Face, weights: dict[str, np.ndarray], fu: dict[str, float]
) -> tuple[dict[int, np.ndarray], float]:
    """Each translational FAP's displacement of every vertex per unit FAP value, (n, 3), and
    the most a brow may be lowered, in FAP units (lowering saturates at it).

    ``weights``: the face's weight layers (:func:`renderer.rigweights.derive_weights`), whose
    ``upper_lip`` and ``lower_lip`` keep each lip's FAPs to its own lip; ``fu``: the FAPU in
    model units per FAP unit (:func:`app.stimuli.fap.fapu_values`). The eyeballs never move.
    """
    v = face.vertices.astype(np.float64)
    fp = face.feature_points
    eyeball = np.zeros(face.n_vertices, bool)
    for side in ("l", "r"):
        eyeball[face.groups[f"eyeball_{side}"]] = True
    mw0, es0 = face.fapu["MW0"], face.fapu["ES0"]

    columns: dict[int, np.ndarray] = {}  # fap -> (n, 3) displacement per unit FAP value
    for name, chain in _CHAINS.items():
        for layer_fps, tag in ((chain, "inner"), (tuple(_OUTER_OF[c] for c in chain), "outer")):
            norm = _chain_weights(v, [fp[c] for c in layer_fps])
            norm *= weights[f"{name}_lip"] * ~eyeball
            for fap in INNER_LIPS:  # vertical ones; a corner FAP moves both lips
                pt, towards = FEATURE_POINT[fap], direction(fap)
                if pt not in chain or towards[0] != 0:
                    continue
                f = fap if tag == "inner" else _OUTER_FAP[fap]
                w = norm[chain.index(pt)] * _pair_share(v, fp, pt, tag)
                columns[f] = columns.get(f, 0) + w[:, None] * towards * fu[FAPS[fap].unit]
    for fap in INNER_LIPS:  # horizontal ones: the corners stretch
        pt, towards = FEATURE_POINT[fap], direction(fap)
        if towards[0] == 0:
            continue
        for f, p, tag in ((fap, pt, "inner"), (_OUTER_FAP[fap], _OUTER_OF[pt], "outer")):
            w = raised_cosine(np.linalg.norm(v - fp[p], axis=1), 0.5 * mw0) * ~eyeball
            columns[f] = (w * _pair_share(v, fp, pt, tag))[:, None] * towards * fu[FAPS[fap].unit]
    for fap in LIP_PUSH_CHIN:  # the chin (2.10) moves with the lower lip
        pt = FEATURE_POINT[fap]
        lip = "upper" if pt in _CHAINS["upper"] else "lower"
        w = raised_cosine(np.linalg.norm(v - fp[pt], axis=1), 0.7 * mw0)
        w = w * weights[f"{lip}_lip"] * ~eyeball
        columns[fap] = w[:, None] * direction(fap) * fu[FAPS[fap].unit]
    brow_lower_limit = np.inf
    upper_lid = {SIDE[f]: FEATURE_POINT[f] for f in EYELIDS if DIRECTION[f][1] < 0}
    for side in ("l", "r"):
        faps = on_side(EYEBROW_RAISE, side)  # inner, middle, outer
        pts = np.array([fp[FEATURE_POINT[f]] for f in faps])
        lid = fp[upper_lid[side]]
        field = brow_field(v, pts, lid, face.fapu["ENS0"]) * ~eyeball
        ens = fu[FAPS[faps[0]].unit]
        room = float(np.min(pts[:, 1] - BROW_RAMP_END * face.fapu["ENS0"] - lid[1]))
        brow_lower_limit = min(brow_lower_limit, BROW_LOWER_ROOM * max(room, 0.0) / 1.5 / ens)
        for j, f in enumerate(faps):
            columns[f] = field[j][:, None] * direction(f) * fu[FAPS[f].unit]
        mask = field.sum(axis=0)
        (f,) = on_side(EYEBROW_SQUEEZE, side)
        squeeze = raised_cosine(np.linalg.norm(v - fp[FEATURE_POINT[f]], axis=1), 0.5 * es0) * mask
        columns[f] = squeeze[:, None] * direction(f) * fu[FAPS[f].unit]
    return columns, brow_lower_limit
