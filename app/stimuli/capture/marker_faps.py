"""FAPs from labelled markers: head pose, lips and eyebrows as thesis sec. 3.2.2-3.2.4 does it.

Equations the redacted copy of the thesis lacks are reconstructed from its text; each
reconstruction is marked *(rec.)* and its constants are fields of :class:`MarkerConstants`.
Distances are Euclidean in pixels; index 0 is the neutral first frame.

Head pose (sec. 3.2.2), from the head frame's post markers TL, TR, BL, BR as the camera sees
them (TL top left in the image):

* roll, eq. 3-4 *(rec.)*: the post directions ``l = TL - BL`` and ``r = TR - BR`` are averaged
  as unit vectors (``VPostAvg``); roll is its angle from the image's vertical,
  ``atan2(-x, -y)`` (y down; positive when the top leans to the image's left, the face's
  right, MPEG-4's positive FAP 50), less the neutral frame's, in 1e-5 rad;
* ``HRatio = |TL - TR| / |BL - BR|`` (eq. 5) grows when the head leans forward (its top
  nears the camera); ``VRatio = |TL - BL| / |TR - BR|`` (eq. 6, the image's left post over
  its right) grows when the head turns to its own left (its right side nears the camera);
* pitch, eq. 7-8 *(rec.)*: ``FAP48 = theta_p * clip((HRatio - HRatio_0) / kp, -1, 1)`` with
  ``kp = 0.15`` and ``theta_p = 17 deg`` (0.296 rad), calibrated on a styrofoam head leaned
  17 degrees; yaw, eq. 9-10 *(rec.)*: the same with ``VRatio``, ``ky = 0.05``,
  ``theta_y = 8 deg`` (0.139 rad). Angles beyond theta_max were out of range.

Lips (sec. 3.2.3): ``VLip = |top - bottom|``, ``HLip = |corner_l - corner_r|``.

* eq. 11-12 *(rec.)*: the pitch correction is the same for a lean forward and back, so it is
  built on ``|HRatio - HRatio_0|``: the pitch it stands for, ``theta = theta_p *
  min(|HRatio - HRatio_0| / kp, 1)``, foreshortens a vertical distance by ``cos(theta)``, and
  the factor is ``1 / cos(theta)``;
* eq. 14: ``CorrectedLipOpening = factor * (VLip - VLip_0) / MNS0 * 1024``;
* eq. 13, 15 *(rec.)*: the Gaussian squashing ``G(A, x) = sign(x) A (1 - exp(-x^2 / (2 (s
  A)^2)))``, "Gaussian shaped", with apex ``A`` (200 for the lips); fig. 16 shows it below
  the identity under 0.3 of the apex and reaching the apex zone rapidly above, so ``s`` puts
  the crossing with the identity at ``crossover = 0.3``: ``s^2 = c^2 / (-2 ln(1 - c))``,
  ``s = 0.355``;
* eq. 16-19: top lip ``-0.1``, bottom lip ``-0.9``, corners ``-0.4`` times the opening
  (FAPs 51/4, 52/5, 59/12 and 60/13: an outer-lip marker moves both contours);
* eq. 20-21: each corner stretches by ``(HLip - HLip_0) / 2 / MW0 * 1024`` (FAPs 53/6, 54/7).

Eyebrows (sec. 3.2.4): ``VIEyebr`` and ``VMEyebr`` (eq. 22-23) are the distances from the
nose bridge to the midpoints of the inner and the middle eyebrow markers; ``VPostAvg`` (eq. 24)
the mean length of the two posts.

* eq. 26-27 *(rec.)*: ``CorrectedInnerEyebrow = (VIEyebr * VPostAvg_0 / VPostAvg -
  VIEyebr_0) / ENS0 * 1024`` (and the middle one alike), less ``brow_pitch_* * pitch``, a
  coupling with pitch that the thesis does not have (0 by default; :mod:`calibration`
  measures it on a calibration capture, since the bridge is not in the eyebrows' plane);
* eq. 28-31: ``G(50, inner)`` to FAPs 31 and 32, ``G(100, middle)`` to 33 and 34;
* a non-causal mean over 5 frames (167 ms at 30 fps) on the eyebrow FAPs.

FAPU in pixels come from the neutral frame: the lip corners' distance is the mouth width MW0
by the FAPU's own definition, which gives the scale at the face; ENS0 and MNS0 are the
subject's, measured in millimetres in the neutral pose (``fapu_mm``).

``squash=False`` skips the Gaussian squashing: the FAPs are then the measurement itself (the
closed-loop test compares those with the truth).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from app.errors import InputError
from app.stimuli.capture.labelling import MarkerTracks
from app.stimuli.fap import AU_RADIANS

#: A typical adult's FAPU in millimetres, used when a subject's are not given.
TYPICAL_FAPU_MM = {"ENS0": 52.0, "MNS0": 20.0, "MW0": 54.0}


@dataclass(frozen=True)
class MarkerConstants:
    """The constants of the marker-to-FAP conversion (see the module text)."""

    kp: float = 0.15
    pitch_max_deg: float = 17.0
    ky: float = 0.05
    yaw_max_deg: float = 8.0
    apex_lips: float = 200.0
    apex_inner_brows: float = 50.0
    apex_middle_brows: float = 100.0
    crossover: float = 0.3
    squash: bool = True
    lip_weights: tuple[float, float, float] = (0.1, 0.9, 0.4)  # top, bottom, corners
    brow_pitch_inner: float = 0.0  # ENS units per radian of pitch
    brow_pitch_middle: float = 0.0
    smooth_s: float = 5 / 30
    fapu_mm: dict[str, float] = field(default_factory=lambda: dict(TYPICAL_FAPU_MM))

    def to_json(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(asdict(self), indent=2) + "\n")

    @classmethod
    def from_json(cls, path: str | Path) -> MarkerConstants:
        """Constants from a JSON object of any of the fields; one line naming a bad key."""
        try:
            data = json.loads(Path(path).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"not a readable JSON file: {exc}", path=path) from None
        if not isinstance(data, dict):
            raise InputError("expected a JSON object of constants", path=path)
        types = {f.name: f for f in fields(cls)}
        out: dict[str, Any] = {}
        for key, value in data.items():
            if key not in types:
                raise InputError(
                    f"unknown constant (known: {', '.join(types)})", path=path, field=key
                )
            out[key] = _checked(key, value, getattr(cls(), key), path)
        return replace(cls(), **out)


#: The thesis' constants with a typical adult's FAPU.
DEFAULT_CONSTANTS = MarkerConstants()


def _checked(key: str, value: Any, default: Any, path: str | Path) -> Any:
    """``value`` if it has the type of ``default`` (and is positive where that matters)."""

    def number(v: Any) -> bool:
        return isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v)

    if isinstance(default, bool):
        ok = isinstance(value, bool)
    elif isinstance(default, dict):
        ok = (
            isinstance(value, dict)
            and set(value) <= set(default)
            and all(number(v) and v > 0 for v in value.values())
        )
        value = {**default, **value} if ok else value
    elif isinstance(default, tuple):
        ok = isinstance(value, list) and len(value) == len(default) and all(map(number, value))
        value = tuple(value) if ok else value
    else:
        ok = number(value) and (value > 0 or key.startswith("brow_pitch"))
    if not ok:
        raise InputError(f"bad value {value!r} (default {default!r})", path=path, field=key)
    return value


def gaussian_squash(x: np.ndarray, apex: float, crossover: float = 0.3) -> np.ndarray:
    """Eq. 13 *(rec.)*: ``sign(x) A (1 - exp(-x^2 / (2 (s A)^2)))``, crossing the identity at
    ``crossover * A``.

    >>> gaussian_squash(np.array([0.0, 15.0, 50.0, -100.0]), 50.0).round(1).tolist()
    [0.0, 15.0, 49.0, -50.0]
    """
    s2 = crossover**2 / (-2.0 * np.log1p(-crossover))
    x = np.asarray(x, dtype=np.float64)
    return np.sign(x) * apex * -np.expm1(-((x / apex) ** 2) / (2.0 * s2))


def post_geometry(tracks: MarkerTracks) -> dict[str, np.ndarray]:
    """HRatio, VRatio (eq. 5-6), roll angle (eq. 3, radians) and mean post length (eq. 24)."""
    tl, tr, bl, br = (tracks[n] for n in ("TL", "TR", "BL", "BR"))
    left, right = tl - bl, tr - br
    left_len, right_len = np.linalg.norm(left, axis=1), np.linalg.norm(right, axis=1)
    avg = left / left_len[:, None] + right / right_len[:, None]
    return {
        "hratio": np.linalg.norm(tl - tr, axis=1) / np.linalg.norm(bl - br, axis=1),
        "vratio": left_len / right_len,
        "roll": np.arctan2(-avg[:, 0], -avg[:, 1]),
        "post": (left_len + right_len) / 2.0,
    }


def head_pose(geometry: dict[str, np.ndarray], c: MarkerConstants) -> dict[int, np.ndarray]:
    """FAPs 48 (pitch), 49 (yaw), 50 (roll) in AU from :func:`post_geometry` (eq. 3-10)."""
    pitch = np.radians(c.pitch_max_deg) * np.clip(
        (geometry["hratio"] - geometry["hratio"][0]) / c.kp, -1.0, 1.0
    )
    yaw = np.radians(c.yaw_max_deg) * np.clip(
        (geometry["vratio"] - geometry["vratio"][0]) / c.ky, -1.0, 1.0
    )
    roll = geometry["roll"] - geometry["roll"][0]
    return {48: pitch / AU_RADIANS, 49: yaw / AU_RADIANS, 50: roll / AU_RADIANS}


def fapu_px(tracks: MarkerTracks, c: MarkerConstants) -> dict[str, float]:
    """ENS0, MNS0, MW0 in pixels from the neutral frame: MW0 is the lip corners' distance."""
    mw0 = float(np.linalg.norm(tracks["lip_corner_l"][0] - tracks["lip_corner_r"][0]))
    per_mm = mw0 / c.fapu_mm["MW0"]
    return {"ENS0": c.fapu_mm["ENS0"] * per_mm, "MNS0": c.fapu_mm["MNS0"] * per_mm, "MW0": mw0}


def lip_faps(
    tracks: MarkerTracks, geometry: dict[str, np.ndarray], c: MarkerConstants
) -> dict[int, np.ndarray]:
    """Outer and inner lip FAPs from the four lip markers (eq. 11-21)."""
    unit = fapu_px(tracks, c)
    vlip = np.linalg.norm(tracks["lip_top"] - tracks["lip_bottom"], axis=1)
    hlip = np.linalg.norm(tracks["lip_corner_l"] - tracks["lip_corner_r"], axis=1)
    lean = np.abs(geometry["hratio"] - geometry["hratio"][0])
    theta = np.radians(c.pitch_max_deg) * np.minimum(lean / c.kp, 1.0)
    opening = (vlip - vlip[0]) / np.cos(theta) / unit["MNS0"] * 1024.0
    if c.squash:
        opening = gaussian_squash(opening, c.apex_lips, c.crossover)
    top, bottom, corner = c.lip_weights
    stretch = (hlip - hlip[0]) / 2.0 / unit["MW0"] * 1024.0
    out: dict[int, np.ndarray] = {}
    for fap, value in (
        (51, -top * opening),
        (52, -bottom * opening),
        (53, stretch),
        (54, stretch),
        (59, -corner * opening),
        (60, -corner * opening),
    ):
        out[fap] = out[fap - 47] = value
    return out


def brow_distances(
    tracks: MarkerTracks, geometry: dict[str, np.ndarray], c: MarkerConstants
) -> dict[str, np.ndarray]:
    """Eq. 22-27 before the pitch coupling: post-corrected brow raises in ENS units."""
    unit = fapu_px(tracks, c)
    bridge = tracks["nose_bridge"]
    scale = geometry["post"][0] / geometry["post"]
    out = {}
    for part in ("inner", "middle"):
        mid = (tracks[f"brow_{part}_l"] + tracks[f"brow_{part}_r"]) / 2.0
        dist = np.linalg.norm(mid - bridge, axis=1)
        out[part] = (dist * scale - dist[0]) / unit["ENS0"] * 1024.0
    return out


def brow_faps(
    tracks: MarkerTracks, geometry: dict[str, np.ndarray], pitch_au: np.ndarray, c: MarkerConstants
) -> dict[int, np.ndarray]:
    """Eyebrow FAPs 31-34 (eq. 22-31), before the 5-frame mean (:func:`mean_filter`)."""
    raised = brow_distances(tracks, geometry, c)
    pitch = pitch_au * AU_RADIANS
    inner = raised["inner"] - c.brow_pitch_inner * pitch
    middle = raised["middle"] - c.brow_pitch_middle * pitch
    if c.squash:
        inner = gaussian_squash(inner, c.apex_inner_brows, c.crossover)
        middle = gaussian_squash(middle, c.apex_middle_brows, c.crossover)
    return {31: inner, 32: inner, 33: middle, 34: middle}


def mean_filter(values: np.ndarray, seconds: float, fps: float) -> np.ndarray:
    """Non-causal moving mean over the odd number of frames nearest ``seconds`` (ends held)."""
    width = max(1, 2 * int(round((seconds * fps - 1) / 2)) + 1)
    return ndimage.uniform_filter1d(np.asarray(values, np.float64), width, mode="nearest")


def marker_faps(
    tracks: MarkerTracks, c: MarkerConstants = DEFAULT_CONSTANTS
) -> dict[int, np.ndarray]:
    """Every FAP the marker set gives, per captured frame (eyebrows not yet averaged)."""
    geometry = post_geometry(tracks)
    head = head_pose(geometry, c)
    return {**head, **lip_faps(tracks, geometry, c), **brow_faps(tracks, geometry, head[48], c)}
