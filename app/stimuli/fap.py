"""The MPEG-4 Facial Animation Parameter table and FAPU names: the one place for these facts.

Follows ISO/IEC 14496-2 Annex C as implemented by the open players Greta and Xface (see the
project's ``docs/stimuli.md``, "The .fap format"): 68 FAPs, each with a unit (a FAPU), one- or
two-way motion and the direction a positive value moves the face. "Left" is the face's own left.

The thesis (sec. 3.2) maps captured marker motion to these FAPs; the channel groups below are
those the prosody conditions drive (thesis sec. 4.3; Le, Ma & Deng 2012 sec. 5-7).

Example
-------
>>> FAPS[48].name, FAPS[48].unit, FAPS[48].positive
('head_pitch', 'AU', 'down')
>>> column_name(48)
'fap48_head_pitch'
>>> parse_column_name('fap23_yaw_l_eyeball')
23
"""

from __future__ import annotations

import re
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

#: Radians per angle unit.
AU_RADIANS = 1e-5


@dataclass(frozen=True)
class Fap:
    """One Facial Animation Parameter."""

    number: int
    name: str
    unit: str  # a key of FAPU
    bidirectional: bool  # False: one-way (values >= 0)
    positive: str  # direction a positive value moves the face


_TABLE: list[tuple[int, str, str, str, str]] = [
    (1, "viseme", "-", "U", "-"),
    (2, "expression", "-", "U", "-"),
    (3, "open_jaw", "MNS", "U", "down"),
    (4, "lower_t_midlip", "MNS", "B", "down"),
    (5, "raise_b_midlip", "MNS", "B", "up"),
    (6, "stretch_l_cornerlip", "MW", "B", "left"),
    (7, "stretch_r_cornerlip", "MW", "B", "right"),
    (8, "lower_t_lip_lm", "MNS", "B", "down"),
    (9, "lower_t_lip_rm", "MNS", "B", "down"),
    (10, "raise_b_lip_lm", "MNS", "B", "up"),
    (11, "raise_b_lip_rm", "MNS", "B", "up"),
    (12, "raise_l_cornerlip", "MNS", "B", "up"),
    (13, "raise_r_cornerlip", "MNS", "B", "up"),
    (14, "thrust_jaw", "MNS", "U", "forward"),
    (15, "shift_jaw", "MW", "B", "right"),
    (16, "push_b_lip", "MNS", "B", "forward"),
    (17, "push_t_lip", "MNS", "B", "forward"),
    (18, "depress_chin", "MNS", "B", "up"),
    (19, "close_t_l_eyelid", "IRISD", "B", "down"),
    (20, "close_t_r_eyelid", "IRISD", "B", "down"),
    (21, "close_b_l_eyelid", "IRISD", "B", "up"),
    (22, "close_b_r_eyelid", "IRISD", "B", "up"),
    (23, "yaw_l_eyeball", "AU", "B", "left"),
    (24, "yaw_r_eyeball", "AU", "B", "left"),
    (25, "pitch_l_eyeball", "AU", "B", "down"),
    (26, "pitch_r_eyeball", "AU", "B", "down"),
    (27, "thrust_l_eyeball", "ES", "B", "forward"),
    (28, "thrust_r_eyeball", "ES", "B", "forward"),
    (29, "dilate_l_pupil", "IRISD", "B", "growing"),
    (30, "dilate_r_pupil", "IRISD", "B", "growing"),
    (31, "raise_l_i_eyebrow", "ENS", "B", "up"),
    (32, "raise_r_i_eyebrow", "ENS", "B", "up"),
    (33, "raise_l_m_eyebrow", "ENS", "B", "up"),
    (34, "raise_r_m_eyebrow", "ENS", "B", "up"),
    (35, "raise_l_o_eyebrow", "ENS", "B", "up"),
    (36, "raise_r_o_eyebrow", "ENS", "B", "up"),
    (37, "squeeze_l_eyebrow", "ES", "B", "right"),
    (38, "squeeze_r_eyebrow", "ES", "B", "left"),
    (39, "puff_l_cheek", "ES", "B", "left"),
    (40, "puff_r_cheek", "ES", "B", "right"),
    (41, "lift_l_cheek", "ENS", "U", "up"),
    (42, "lift_r_cheek", "ENS", "U", "up"),
    (43, "shift_tongue_tip", "MW", "B", "right"),
    (44, "raise_tongue_tip", "MNS", "B", "up"),
    (45, "thrust_tongue_tip", "MW", "B", "forward"),
    (46, "raise_tongue", "MNS", "B", "up"),
    (47, "tongue_roll", "AU", "U", "concave upward"),
    (48, "head_pitch", "AU", "B", "down"),
    (49, "head_yaw", "AU", "B", "left"),
    (50, "head_roll", "AU", "B", "right"),
    (51, "lower_t_midlip_o", "MNS", "B", "down"),
    (52, "raise_b_midlip_o", "MNS", "B", "up"),
    (53, "stretch_l_cornerlip_o", "MW", "B", "left"),
    (54, "stretch_r_cornerlip_o", "MW", "B", "right"),
    (55, "lower_t_lip_lm_o", "MNS", "B", "down"),
    (56, "lower_t_lip_rm_o", "MNS", "B", "down"),
    (57, "raise_b_lip_lm_o", "MNS", "B", "up"),
    (58, "raise_b_lip_rm_o", "MNS", "B", "up"),
    (59, "raise_l_cornerlip_o", "MNS", "B", "up"),
    (60, "raise_r_cornerlip_o", "MNS", "B", "up"),
    (61, "stretch_l_nose", "ENS", "B", "left"),
    (62, "stretch_r_nose", "ENS", "B", "right"),
    (63, "raise_nose", "ENS", "B", "up"),
    (64, "bend_nose", "ENS", "B", "right"),
    (65, "raise_l_ear", "ENS", "B", "up"),
    (66, "raise_r_ear", "ENS", "B", "up"),
    (67, "pull_l_ear", "ENS", "B", "left"),
    (68, "pull_r_ear", "ENS", "B", "right"),
]

#: FAP number -> Fap, for 1..68.
FAPS: dict[int, Fap] = {
    n: Fap(n, name, unit, way == "B", positive) for n, name, unit, way, positive in _TABLE
}
assert len(FAPS) == N_FAPS and sorted(FAPS) == list(range(1, N_FAPS + 1))

# Channel groups used by the prosody conditions.
JAW_LIPS: tuple[int, ...] = tuple(range(3, 19)) + tuple(range(51, 61))
EYELIDS: tuple[int, ...] = (19, 20, 21, 22)
GAZE: tuple[int, ...] = (23, 24, 25, 26)
EYEBROWS: tuple[int, ...] = tuple(range(31, 39))
EYEBROW_RAISE: tuple[int, ...] = tuple(range(31, 37))
HEAD: tuple[int, ...] = (48, 49, 50)
HEAD_PITCH, HEAD_YAW, HEAD_ROLL = 48, 49, 50

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
