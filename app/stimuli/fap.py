"""The MPEG-4 Facial Animation Parameter table and FAPU names: the one place for these facts.

Follows ISO/IEC 14496-2 Annex C as implemented by the open players Greta and Xface (the
project reference ``mpeg4-fap``: "The 68 FAPs", "Feature points (FDP)" and "FAPU"; see also
``docs/reference/stimuli.md``, "The .fap format"): 68 FAPs, each with a unit (a FAPU), one- or
two-way motion, the direction a positive value moves the face and the feature point it moves. "Left"
is the face's own left; the axes are Xface's: +x the face's left, +y up, +z forward (towards the
viewer).

The thesis (sec. 3.2) maps captured marker motion to these FAPs; the channel groups below are
those the prosody conditions drive (thesis sec. 4.3; Le, Ma & Deng 2012 sec. 5-7).

Example
-------
>>> FAPS[48].name, FAPS[48].unit, FAPS[48].positive
('head_pitch', 'AU', 'down')
>>> FAPS[31].feature_point, FAPS[31].direction, FAPS[31].side
('4.1', (0.0, 1.0, 0.0), 'l')
>>> FAPS[HEAD_YAW].axis
'y'
>>> fapu_values({"ES0": 1024.0, "IRISD0": 512.0, "ENS0": 2048.0, "MNS0": 1024.0, "MW0": 1024.0})
{'ES': 1.0, 'IRISD': 0.5, 'ENS': 2.0, 'MNS': 1.0, 'MW': 1.0}
>>> column_name(48)
'fap48_head_pitch'
>>> parse_column_name('fap23_yaw_l_eyeball')
23
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

N_FAPS = 68

#: FAPU names and what each measures on the neutral face (divided by 1024, angles excepted).
FAPU = {
    "IRISD": "iris diameter: upper to lower eyelid in the neutral face (3.1-3.3) / 1024",
    "ES": "eye separation: between the pupils (3.5-3.6) / 1024",
    "ENS": "eye-nose separation: eye line to nose bottom (9.15) / 1024",
    "MNS": "mouth-nose separation: nose bottom (9.15) to mouth (2.2) / 1024",
    "MW": "mouth width: between the lip corners (8.3-8.4) / 1024",
    "AU": "angle unit: 1e-5 rad",
}

#: The neutral-face distance (in model units) each length FAPU is measured as, by FAPU name;
#: a face file states these distances (``ES0`` ...), a FAP value counts FAPU = distance / 1024.
FAPU_DISTANCE: dict[str, str] = {
    "ES": "ES0",
    "IRISD": "IRISD0",
    "ENS": "ENS0",
    "MNS": "MNS0",
    "MW": "MW0",
}
FAPU_DIVISOR = 1024.0

#: Radians per angle unit, and degrees.
AU_RADIANS = 1e-5
DEG_PER_AU = AU_RADIANS * 180.0 / math.pi


def fapu_values(distances: Mapping[str, float]) -> dict[str, float]:
    """The length FAPUs of a face from its neutral distances: ``{"ENS": ENS0 / 1024, ...}``.

    ``distances`` maps each name of :data:`FAPU_DISTANCE` (``ES0``, ``IRISD0``, ``ENS0``,
    ``MNS0``, ``MW0``) to its length in model units (reference ``mpeg4-fap``, "FAPU").
    """
    return {unit: distances[name] / FAPU_DIVISOR for unit, name in FAPU_DISTANCE.items()}


#: Unit vectors of the straight directions a positive FAP value moves a feature point.
_DIRECTIONS: dict[str, tuple[float, float, float]] = {
    "up": (0.0, 1.0, 0.0),
    "down": (0.0, -1.0, 0.0),
    "left": (1.0, 0.0, 0.0),
    "right": (-1.0, 0.0, 0.0),
    "forward": (0.0, 0.0, 1.0),
}
#: Rotation axes: with Xface's axes a positive pitch (down), yaw (to the face's left) and roll
#: (to the face's right) are each a positive right-handed turn about this axis.
_AXES = {"pitch": "x", "yaw": "y", "roll": "z"}


@dataclass(frozen=True)
class Fap:
    """One Facial Animation Parameter."""

    number: int
    name: str
    unit: str  # a key of FAPU
    bidirectional: bool  # False: one-way (values >= 0)
    positive: str  # direction a positive value moves the face
    feature_point: str | None  # the FDP it moves (a rotation: its pivot, 7.1; an eye: its pupil)

    @property
    def axis(self) -> str | None:
        """``"x"``, ``"y"`` or ``"z"``: the axis a rotation FAP (unit AU) turns about."""
        if self.unit != "AU" or self.positive not in _DIRECTIONS:  # tongue roll: a curl
            return None
        return next((a for word, a in _AXES.items() if word in self.name.split("_")), None)

    @property
    def direction(self) -> tuple[float, float, float] | None:
        """Unit vector a positive value moves the feature point, or None for a rotation (see
        :attr:`axis`) and the FAPs that do not move it along a line (pupil, tongue roll)."""
        return None if self.unit == "AU" else _DIRECTIONS.get(self.positive)

    @property
    def side(self) -> str | None:
        """``"l"`` or ``"r"``: the side of the face it moves, None for the midline."""
        words = set(self.name.split("_"))
        return "l" if words & {"l", "lm"} else "r" if words & {"r", "rm"} else None


#: number, name, FAPU, U(ni)/B(idirectional), positive direction, feature point.
_TABLE: list[tuple[int, str, str, str, str, str | None]] = [
    (1, "viseme", "-", "U", "-", None),
    (2, "expression", "-", "U", "-", None),
    (3, "open_jaw", "MNS", "U", "down", "2.1"),
    (4, "lower_t_midlip", "MNS", "B", "down", "2.2"),
    (5, "raise_b_midlip", "MNS", "B", "up", "2.3"),
    (6, "stretch_l_cornerlip", "MW", "B", "left", "2.4"),
    (7, "stretch_r_cornerlip", "MW", "B", "right", "2.5"),
    (8, "lower_t_lip_lm", "MNS", "B", "down", "2.6"),
    (9, "lower_t_lip_rm", "MNS", "B", "down", "2.7"),
    (10, "raise_b_lip_lm", "MNS", "B", "up", "2.8"),
    (11, "raise_b_lip_rm", "MNS", "B", "up", "2.9"),
    (12, "raise_l_cornerlip", "MNS", "B", "up", "2.4"),
    (13, "raise_r_cornerlip", "MNS", "B", "up", "2.5"),
    (14, "thrust_jaw", "MNS", "U", "forward", "2.1"),
    (15, "shift_jaw", "MW", "B", "right", "2.1"),
    (16, "push_b_lip", "MNS", "B", "forward", "2.3"),
    (17, "push_t_lip", "MNS", "B", "forward", "2.2"),
    (18, "depress_chin", "MNS", "B", "up", "2.10"),
    (19, "close_t_l_eyelid", "IRISD", "B", "down", "3.1"),
    (20, "close_t_r_eyelid", "IRISD", "B", "down", "3.2"),
    (21, "close_b_l_eyelid", "IRISD", "B", "up", "3.3"),
    (22, "close_b_r_eyelid", "IRISD", "B", "up", "3.4"),
    (23, "yaw_l_eyeball", "AU", "B", "left", "3.5"),
    (24, "yaw_r_eyeball", "AU", "B", "left", "3.6"),
    (25, "pitch_l_eyeball", "AU", "B", "down", "3.5"),
    (26, "pitch_r_eyeball", "AU", "B", "down", "3.6"),
    (27, "thrust_l_eyeball", "ES", "B", "forward", "3.5"),
    (28, "thrust_r_eyeball", "ES", "B", "forward", "3.6"),
    (29, "dilate_l_pupil", "IRISD", "B", "growing", "3.5"),
    (30, "dilate_r_pupil", "IRISD", "B", "growing", "3.6"),
    (31, "raise_l_i_eyebrow", "ENS", "B", "up", "4.1"),
    (32, "raise_r_i_eyebrow", "ENS", "B", "up", "4.2"),
    (33, "raise_l_m_eyebrow", "ENS", "B", "up", "4.3"),
    (34, "raise_r_m_eyebrow", "ENS", "B", "up", "4.4"),
    (35, "raise_l_o_eyebrow", "ENS", "B", "up", "4.5"),
    (36, "raise_r_o_eyebrow", "ENS", "B", "up", "4.6"),
    (37, "squeeze_l_eyebrow", "ES", "B", "right", "4.1"),
    (38, "squeeze_r_eyebrow", "ES", "B", "left", "4.2"),
    (39, "puff_l_cheek", "ES", "B", "left", "5.1"),
    (40, "puff_r_cheek", "ES", "B", "right", "5.2"),
    (41, "lift_l_cheek", "ENS", "U", "up", "5.3"),
    (42, "lift_r_cheek", "ENS", "U", "up", "5.4"),
    (43, "shift_tongue_tip", "MW", "B", "right", "6.1"),
    (44, "raise_tongue_tip", "MNS", "B", "up", "6.1"),
    (45, "thrust_tongue_tip", "MW", "B", "forward", "6.1"),
    (46, "raise_tongue", "MNS", "B", "up", "6.2"),
    (47, "tongue_roll", "AU", "U", "concave upward", "6.3"),
    (48, "head_pitch", "AU", "B", "down", "7.1"),
    (49, "head_yaw", "AU", "B", "left", "7.1"),
    (50, "head_roll", "AU", "B", "right", "7.1"),
    (51, "lower_t_midlip_o", "MNS", "B", "down", "8.1"),
    (52, "raise_b_midlip_o", "MNS", "B", "up", "8.2"),
    (53, "stretch_l_cornerlip_o", "MW", "B", "left", "8.3"),
    (54, "stretch_r_cornerlip_o", "MW", "B", "right", "8.4"),
    (55, "lower_t_lip_lm_o", "MNS", "B", "down", "8.5"),
    (56, "lower_t_lip_rm_o", "MNS", "B", "down", "8.6"),
    (57, "raise_b_lip_lm_o", "MNS", "B", "up", "8.7"),
    (58, "raise_b_lip_rm_o", "MNS", "B", "up", "8.8"),
    (59, "raise_l_cornerlip_o", "MNS", "B", "up", "8.3"),
    (60, "raise_r_cornerlip_o", "MNS", "B", "up", "8.4"),
    (61, "stretch_l_nose", "ENS", "B", "left", "9.1"),
    (62, "stretch_r_nose", "ENS", "B", "right", "9.2"),
    (63, "raise_nose", "ENS", "B", "up", "9.3"),
    (64, "bend_nose", "ENS", "B", "right", "9.3"),
    (65, "raise_l_ear", "ENS", "B", "up", "10.1"),
    (66, "raise_r_ear", "ENS", "B", "up", "10.2"),
    (67, "pull_l_ear", "ENS", "B", "left", "10.3"),
    (68, "pull_r_ear", "ENS", "B", "right", "10.4"),
]

#: FAP number -> Fap, for 1..68.
FAPS: dict[int, Fap] = {
    n: Fap(n, name, unit, way == "B", positive, point)
    for n, name, unit, way, positive, point in _TABLE
}
assert len(FAPS) == N_FAPS and sorted(FAPS) == list(range(1, N_FAPS + 1))

#: Per FAP, where the table gives it: the feature point it moves, the unit vector a positive
#: value moves it along (translations), the axis it turns about (rotations) and its side.
FEATURE_POINT: dict[int, str] = {n: f.feature_point for n, f in FAPS.items() if f.feature_point}
DIRECTION: dict[int, tuple[float, float, float]] = {
    n: f.direction for n, f in FAPS.items() if f.direction
}
AXIS: dict[int, str] = {n: f.axis for n, f in FAPS.items() if f.axis}
SIDE: dict[int, str] = {n: f.side for n, f in FAPS.items() if f.side}

# Channel groups used by the prosody conditions.
JAW_LIPS: tuple[int, ...] = tuple(range(3, 19)) + tuple(range(51, 61))
EYELIDS: tuple[int, ...] = (19, 20, 21, 22)
GAZE: tuple[int, ...] = (23, 24, 25, 26)
EYEBROWS: tuple[int, ...] = tuple(range(31, 39))
EYEBROW_RAISE: tuple[int, ...] = tuple(range(31, 37))
HEAD: tuple[int, ...] = (48, 49, 50)

#: FAP number by name, e.g. ``NUMBER["head_pitch"] == 48``.
NUMBER: dict[str, int] = {f.name: n for n, f in FAPS.items()}
HEAD_PITCH, HEAD_YAW, HEAD_ROLL = (NUMBER[n] for n in ("head_pitch", "head_yaw", "head_roll"))
OPEN_JAW, THRUST_JAW, SHIFT_JAW = (NUMBER[n] for n in ("open_jaw", "thrust_jaw", "shift_jaw"))
#: Lip FAPs on the inner lip contour (2.x) and the outer ones (8.x) that mirror them in order.
INNER_LIPS: tuple[int, ...] = tuple(range(4, 14))
OUTER_LIPS: tuple[int, ...] = tuple(range(51, 61))
#: Push the lips forward and raise the chin.
LIP_PUSH_CHIN: tuple[int, ...] = (16, 17, 18)
EYEBROW_SQUEEZE: tuple[int, ...] = (37, 38)

_COLUMN = re.compile(r"^fap(\d{1,2})(?:_[a-z0-9_]+)?$")


def column_name(fap: int) -> str:
    """CSV column name of a FAP, e.g. ``fap48_head_pitch``."""
    return f"fap{fap}_{FAPS[fap].name}"


def parse_column_name(name: str) -> int:
    """FAP number of a CSV column named ``fapN`` or ``fapN_<anything>``.

    Raises ``ValueError`` for any other name or a number outside 1..68.
    """
    m = _COLUMN.match(name.strip())
    if not m or not 1 <= int(m.group(1)) <= N_FAPS:
        raise ValueError(
            f"not a FAP column (expected fap1..fap68, e.g. fap48_head_pitch): {name!r}"
        )
    return int(m.group(1))


def check_fap(fap: int) -> int:
    """Return ``fap`` if it is a FAP number 1..68, else raise ``ValueError``."""
    if isinstance(fap, bool) or not 1 <= int(fap) <= N_FAPS:
        raise ValueError(f"FAP numbers run from 1 to {N_FAPS}, got {fap!r}")
    return int(fap)
