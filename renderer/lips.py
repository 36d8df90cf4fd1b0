"""The lip FAPs on ARKit's mouth blendshapes, so an avatar speaks.

The ARKit table of the capture import (:mod:`app.stimuli.capture.arkit`) drives the jaw, brows,
lids, head and eyes; the lips (FAP 4-13 inner, 51-60 outer, 16-17 push) have no entry in it, so
an avatar's lips never moved. This module reads a frame's lip FAPs as ARKit's mouth shapes
(:func:`mouth_weights`) and gives each shape the FAPs it stands for at weight 1
(:data:`MOUTH_SHAPES`, which ``facepair face export`` bakes into the exported head).

Sources. The FAP directions are MPEG-4's (ISO/IEC 14496-2 Annex C, as the open players Greta and
Xface implement them; the FAP table of :mod:`app.stimuli.fap`): FAP 4, 8, 9 move the upper
lip's middle, left and right *down*; FAP 5, 10, 11 the lower lip's *up*; FAP 6 / 7 stretch the
left / right corner *outwards*; FAP 12 / 13 *raise* a corner; FAP 16 / 17 push the lower / upper
lip *forward*; "left" is the face's own. FAP 51-60 are the outer-lip versions of 4-13. What each
shape does is Apple's description of it (ARKit, ``ARFaceAnchor.BlendShapeLocation``):
``mouthUpperUp*`` "upward movement of the upper lip", ``mouthLowerDown*`` "downward movement of
the lower lip", ``mouthClose`` "closure of the lips independent of jaw position",
``mouthPress*`` "upward compression of the lower lip", ``mouthStretch*`` a corner pulled
outward, ``mouthPucker`` "contraction and compression of both closed lips", ``mouthFunnel``
"contraction of both lips into an open shape", ``mouthSmile*`` / ``mouthFrown*`` a corner up /
down, ``mouthShrug*`` a lip moved outward, ``mouthRoll*`` a lip rolled inward.

Inverse (:func:`mouth_weights`), each FAP's sign to one shape, weight = |value| / :data:`LIP`:

============================  ===========================  =============================
lip FAP (inner / outer)       negative                     positive
============================  ===========================  =============================
8 / 9 upper lip left / right  mouthUpperUpLeft / Right     mouthClose (mean of sides)
10 / 11 lower lip l / r       mouthLowerDownLeft / Right   mouthPressLeft / Right
6 / 7 corner stretch l / r    mouthPucker, mouthFunnel     mouthStretchLeft / Right
12 / 13 corner raise l / r    mouthFrownLeft / Right       mouthSmileLeft / Right
16 / 17 push lower / upper    mouthRollLower / Upper       mouthShrugLower / Upper
============================  ===========================  =============================

Where both side FAPs of a lip are zero they take its middle value (FAP 4 for 8, 9; FAP 5 for
10, 11), so a track with the middle lips only (the demo's, most trackers') moves the whole lip.
Inner and outer FAPs are merged as Xface does: where one of a pair is zero the other stands for
both, else their mean. Corners drawn in are a pucker with the lips together and a funnel with them
apart: the inward weight is shared by ``open = min((-FAP 4 - FAP 5)^+ / LIP, 1)``, funnel =
inward x open, pucker = inward x (1 - open). The amplitude is a calibration, as the brows' 100
and the jaw's 800 units are: :data:`LIP` = 200 units at weight 1 (MNS is about 30 mm / 1024,
so a lip moves about 6 mm, about what ARKit's shapes do at 1).

Forward (:data:`MOUTH_SHAPES`, what ``facepair face export`` bakes): each shape is the FAPs
the inverse reads as that shape alone at weight 1 (the middle lip taking half of each side's
value), so the exported head driven by a track moves its lips as the built-in head does.

Example
-------
>>> faps = np.zeros(68); faps[[4 - 1, 5 - 1]] = -40.0    # the demo's lips apart at most
>>> w = mouth_weights(faps)
>>> float(w["MouthUpperUpLeft"]), float(w["MouthLowerDownRight"]), float(w["MouthClose"])
(0.2, 0.2, 0.0)
"""

from __future__ import annotations

import numpy as np

#: FAP units of a lip at weight 1 (MNS for the vertical FAPs, MW for the corners' stretch).
LIP = 200.0
#: Inner lip FAPs and their outer twins (FAP k + 47, MPEG-4: "outer-lip versions of 4-13").
INNER = tuple(range(4, 14))
OUTER = {k: k + 47 for k in INNER}

#: ARKit mouth shape (Live Link Face's spelling, as the capture table) -> FAP values at weight 1.
MOUTH_SHAPES: dict[str, dict[int, float]] = {
    "MouthUpperUpLeft": {8: -LIP, 4: -LIP / 2},
    "MouthUpperUpRight": {9: -LIP, 4: -LIP / 2},
    "MouthClose": {8: LIP, 9: LIP, 4: LIP},
    "MouthLowerDownLeft": {10: -LIP, 5: -LIP / 2},
    "MouthLowerDownRight": {11: -LIP, 5: -LIP / 2},
    "MouthPressLeft": {10: LIP, 5: LIP / 2},
    "MouthPressRight": {11: LIP, 5: LIP / 2},
    "MouthStretchLeft": {6: LIP},
    "MouthStretchRight": {7: LIP},
    "MouthPucker": {6: -LIP, 7: -LIP},
    "MouthFunnel": {6: -LIP, 7: -LIP},
    "MouthSmileLeft": {12: LIP},
    "MouthSmileRight": {13: LIP},
    "MouthFrownLeft": {12: -LIP},
    "MouthFrownRight": {13: -LIP},
    "MouthShrugLower": {16: LIP},
    "MouthShrugUpper": {17: LIP},
    "MouthRollLower": {16: -LIP},
    "MouthRollUpper": {17: -LIP},
}


def mouth_faps(name: str) -> np.ndarray:
    """The 68 FAP values mouth shape ``name`` stands for at weight 1 (outer lips as inner)."""
    out = np.zeros(68)
    for fap, value in MOUTH_SHAPES[name].items():
        out[fap - 1] = value
        if fap in OUTER:
            out[OUTER[fap] - 1] = value
    return out


def mouth_weights(faps: np.ndarray) -> dict[str, np.ndarray]:
    """Per-frame ARKit mouth weights of FAP frames ((n, 68) or one frame of 68).

    The inverse table of the module docstring. Weights are not clipped (the avatar clips to
    ARKit's 0..1, as for the other shapes).
    """
    f = np.asarray(faps, dtype=np.float64)

    def lip(fap: int) -> np.ndarray:  # inner and outer merged, Xface's rule
        inner, outer = f[..., fap - 1], f[..., OUTER[fap] - 1]
        return np.where(outer == 0, inner, np.where(inner == 0, outer, (inner + outer) / 2))

    def pos(x: np.ndarray) -> np.ndarray:
        return np.maximum(x, 0.0) / LIP

    mid_up, mid_low = lip(4), lip(5)
    side = {}
    for mid, pair in ((mid_up, (8, 9)), (mid_low, (10, 11))):
        given = (lip(pair[0]) != 0) | (lip(pair[1]) != 0)
        for k in pair:
            side[k] = np.where(given, lip(k), mid)
    inward = (pos(-lip(6)) + pos(-lip(7))) / 2
    opening = np.minimum(pos(-mid_up) + pos(-mid_low), 1.0)
    return {
        "MouthUpperUpLeft": pos(-side[8]),
        "MouthUpperUpRight": pos(-side[9]),
        "MouthClose": (pos(side[8]) + pos(side[9])) / 2,
        "MouthLowerDownLeft": pos(-side[10]),
        "MouthLowerDownRight": pos(-side[11]),
        "MouthPressLeft": pos(side[10]),
        "MouthPressRight": pos(side[11]),
        "MouthStretchLeft": pos(lip(6)),
        "MouthStretchRight": pos(lip(7)),
        "MouthPucker": inward * (1.0 - opening),
        "MouthFunnel": inward * opening,
        "MouthSmileLeft": pos(lip(12)),
        "MouthSmileRight": pos(lip(13)),
        "MouthFrownLeft": pos(-lip(12)),
        "MouthFrownRight": pos(-lip(13)),
        "MouthShrugLower": pos(f[..., 15]),
        "MouthShrugUpper": pos(f[..., 16]),
        "MouthRollLower": pos(-f[..., 15]),
        "MouthRollUpper": pos(-f[..., 16]),
    }
