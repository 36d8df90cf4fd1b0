"""Per-vertex weight layers of a face's rig, derived from its feature points where not given.

A face may supply any layer of :data:`renderer.face.WEIGHT_LAYERS`; the others are derived here
from the MPEG-4 feature points and FAPU, so that a bring-your-own mesh animates without
hand-painted weights:

* ``upper_lip`` / ``lower_lip``: vertices above / below the lip line (mean height of 2.2 and
  2.3). The two lips must not share vertices between the corners (Parke's unconnected lips,
  thesis sec. 2.1.2), or opening the jaw tears the shared ones.
* ``jaw``: 1 below the lip line in front of the hinge; beside the lip corners (beyond MW0 / 2)
  the weight fades smoothly over one MNS0 around the lip line, so the cheeks stretch.
* ``eyelid_upper_*`` / ``eyelid_lower_*``: raised cosine about 3.1-3.4 (radius 0.3 ES0) above /
  below the pupil line, eyeballs excluded.
* ``head``: 1 (the whole mesh turns about 7.1) unless the face gives a ``head`` layer.
"""

from __future__ import annotations

import numpy as np

from renderer.face import WEIGHT_LAYERS, Face


def _smooth(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def derive_weights(face: Face) -> dict[str, np.ndarray]:
    """All rig layers of ``face`` as float64 arrays of length ``n_vertices``."""
    v = face.vertices.astype(np.float64)
    fp, fapu = face.feature_points, face.fapu
    n = face.n_vertices
    eyeball = np.zeros(n, bool)
    for eye in ("l", "r"):
        eyeball[face.groups[f"eyeball_{eye}"]] = True
    lip_y = (fp["2.2"][1] + fp["2.3"][1]) / 2.0
    out: dict[str, np.ndarray] = {
        "head": np.ones(n),
        "upper_lip": (v[:, 1] >= lip_y).astype(float),
        "lower_lip": (v[:, 1] < lip_y).astype(float),
    }
    hinge = face.hinge()
    mx = (fp["2.4"][0] + fp["2.5"][0]) / 2.0
    side = _smooth((np.abs(v[:, 0] - mx) - 0.5 * fapu["MW0"]) / (0.25 * fapu["MW0"]))
    t = (v[:, 1] - lip_y) / (0.5 * fapu["MNS0"])
    lateral = 0.5 * (1.0 - np.sin(np.pi / 2 * np.clip(t, -1, 1)))
    front = _smooth((v[:, 2] - hinge[2]) / (0.3 * fapu["ENS0"]))
    out["jaw"] = ((1 - side) * out["lower_lip"] + side * lateral) * front * ~eyeball
    eye_y = (fp["3.5"][1] + fp["3.6"][1]) / 2.0
    for lid, k, above in (("upper", 1, True), ("lower", 3, False)):
        for s, off in (("l", 0), ("r", 1)):
            d = np.linalg.norm(v - fp[f"3.{k + off}"], axis=1)
            r = 0.3 * fapu["ES0"]
            w = np.where(d < r, 0.5 * (1 + np.cos(np.pi * np.minimum(d / r, 1))), 0.0)
            half = (v[:, 1] >= eye_y) if above else (v[:, 1] < eye_y)
            out[f"eyelid_{lid}_{s}"] = w * half * ~eyeball
    for name in WEIGHT_LAYERS:
        if name in face.weights:
            out[name] = np.asarray(face.weights[name], dtype=np.float64)
    return out
