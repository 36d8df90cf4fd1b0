"""BVH (Biovision hierarchy) skeletons: the head and neck joints' rotations to FAP 48-50.

Gesture data sets and the systems trained on them (the GENEA challenges, Talking With Hands,
BEAT) give motion as BVH: a hierarchy of joints, then one line of channel values per frame,
parsed by :mod:`app.stimuli.capture.bvhfile` (anything malformed is one
:class:`~app.errors.InputError` naming the file and the line).

Conventions, as the format and these data sets use them, and how they are read:

* A joint's rotation is the product of its rotation channels in the order listed
  (``Zrotation Xrotation Yrotation``: ``R = Rz @ Rx @ Ry``), right-handed, degrees, about the
  axes of the rest pose (BVH joints carry no orientation of their own); a child's world
  rotation is its parent's times its own.
* The skeleton stands Y up. It faces +Z with its left on +X (the face frame of
  :mod:`~app.stimuli.capture.headframe`) unless its left-hand joints sit on -X in the rest
  pose, in which case it faces -Z and the rotations are turned half a turn about Y. A neck that
  does not run up +Y at rest is refused with one line (export the file Y up).
* The head's rotation relative to the torso is the product of the neck joints' (the head's
  ancestors whose names hold ``neck``: GENEA's ``Neck``, ``Neck1``) and the head's own
  rotations; FAP 48-50 are its pitch, yaw and roll in the renderer's order. The rest pose is
  the neutral by default; the take's median or a window can be chosen (``neutral``).

Example
-------
>>> import tempfile
>>> text = '''HIERARCHY
... ROOT Hips
... {
...   OFFSET 0 90 0
...   CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
...   JOINT Neck
...   {
...     OFFSET 0 50 0
...     CHANNELS 3 Zrotation Xrotation Yrotation
...     JOINT Head
...     {
...       OFFSET 0 10 0
...       CHANNELS 3 Zrotation Xrotation Yrotation
...       End Site
...       {
...         OFFSET 0 15 0
...       }
...     }
...   }
... }
... MOTION
... Frames: 2
... Frame Time: 0.5
... 0 90 0 0 0 0 0 5 0 0 5 0
... 0 90 0 0 0 0 0 0 0 0 0 -10
... '''
>>> path = Path(tempfile.mkdtemp()) / "nod.bvh"
>>> _ = path.write_text(text)
>>> track = read_bvh(path, fps=2.0)
>>> degrees = {fap: np.degrees(track[fap] * 1e-5).round(6).tolist() for fap in (48, 49)}
>>> degrees
{48: [10.0, 0.0], 49: [0.0, -10.0]}
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.errors import InputError
from app.stimuli.capture.bvhfile import Joint, parse_bvh
from app.stimuli.capture.headframe import Neutral, head_angles, relative_to_neutral, rotations
from app.stimuli.capture.timeline import MAX_GAP_S, to_track
from app.stimuli.fap import AU_RADIANS
from app.stimuli.track import MotionTrack

#: Half a turn about Y: a skeleton facing -Z seen in the face frame.
_TURN_Y = np.diag([-1.0, 1.0, -1.0])


def _is_head(name: str) -> bool:
    n = name.lower().split(":")[-1]
    return n.endswith("head") and not any(w in n for w in ("end", "top", "nub", "site"))


def head_chain(joints: list[Joint]) -> list[int]:
    """Indices of the neck joints and the head, from the torso down."""
    head = next((k for k, j in enumerate(joints) if _is_head(j.name)), None)
    if head is None:
        raise InputError("no head joint (a joint named ...Head) in the skeleton")
    chain = [head]
    while joints[chain[0]].parent >= 0 and "neck" in joints[joints[chain[0]].parent].name.lower():
        chain.insert(0, joints[chain[0]].parent)
    return chain


def _rest_positions(joints: list[Joint]) -> np.ndarray:
    pos = np.zeros((len(joints), 3))
    for k, joint in enumerate(joints):
        offset = joint.offset if joint.offset is not None else np.zeros(3)
        pos[k] = (pos[joint.parent] if joint.parent >= 0 else 0.0) + offset
    return pos


def _facing(joints: list[Joint]) -> tuple[float, str]:
    """+1 for a skeleton facing +Z (its left on +X), -1 for -Z, from a Left/Right joint pair."""
    pos = _rest_positions(joints)
    index = {j.name.lower(): k for k, j in enumerate(joints)}
    for k, joint in enumerate(joints):
        name = joint.name.lower()
        other = index.get(name.replace("left", "right"))
        if "left" in name and other is not None:
            dx = pos[k, 0] - pos[other, 0]
            if abs(dx) > 1e-9:
                side = "+x" if dx > 0 else "-x"
                return (1.0 if dx > 0 else -1.0), f"{joint.name[:40]} on {side}"
    return 1.0, "no Left/Right joints: taken as facing +Z"


def read_bvh(
    path: str | Path,
    fps: float = 30.0,
    *,
    neutral: Neutral | None = None,
    max_gap_s: float = MAX_GAP_S,
) -> MotionTrack:
    """The head of a BVH skeleton, relative to its torso, as FAP 48-50 at ``fps``.

    ``neutral`` defaults to the rest pose (``Neutral("none")``). ``metadata["capture"]``
    reports the joints used (``joints``), the facing and the neutral.
    """
    neutral = neutral or Neutral("none")
    p = str(path)
    skeleton = parse_bvh(path)
    joints = skeleton.joints
    try:
        chain = head_chain(joints)
    except InputError as exc:
        raise InputError(exc.message, path=p) from None
    torso = joints[chain[0]].parent
    neck = _rest_positions(joints)[chain[-1]] - (
        _rest_positions(joints)[torso] if torso >= 0 else 0.0
    )
    end = joints[chain[-1]].end_site
    up = neck + (end if end is not None else 0.0)
    if np.linalg.norm(up) > 0 and up[1] < 0.7 * np.linalg.norm(up):
        raise InputError(
            f"the neck runs along ({up[0]:.3g}, {up[1]:.3g}, {up[2]:.3g}) at rest, not up +Y: "
            "facepair reads BVH skeletons that stand Y up (export the file Y up)",
            path=p,
        )
    sign, facing = _facing(joints)
    n = len(skeleton.motion)
    rot = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    for k in chain:
        joint = joints[k]
        turns = [
            (c[0].upper(), joint.first + i)
            for i, c in enumerate(joint.channels)
            if c.lower().endswith("rotation")
        ]
        if turns:
            order = "".join(a for a, _ in turns)
            angles = np.radians(skeleton.motion[:, [i for _, i in turns]])
            rot = rot @ rotations(order, angles)
    if sign < 0:
        rot = _TURN_Y @ rot @ _TURN_Y
    times = np.arange(n) * skeleton.frame_time
    relative, base = relative_to_neutral(rot, times, np.ones(n, bool), neutral, p)
    angles = head_angles(relative) / AU_RADIANS
    track, report = to_track(
        times,
        {48: angles[:, 0], 49: angles[:, 1], 50: angles[:, 2]},
        np.ones(n, bool),
        fps=fps,
        path=p,
        max_gap_s=max_gap_s,
        rows=skeleton.lines,
        name=Path(path).stem,
        source=f"BVH {Path(path).name}",
    )
    report.update(
        joints=[joints[k].name for k in chain],
        torso=joints[torso].name if torso >= 0 else None,
        facing=facing,
        neutral={
            "method": neutral.method,
            "described": (
                "the skeleton's rest pose" if neutral.method == "none" else neutral.describe()
            ),
            "from": "the rest pose",
            "pitch_deg": round(float(np.degrees(base[0])), 2),
            "yaw_deg": round(float(np.degrees(base[1])), 2),
            "roll_deg": round(float(np.degrees(base[2])), 2),
        },
        missing={},
        warnings=[f"head from joints {', '.join(joints[k].name for k in chain)} ({facing})"],
    )
    return track.replace(metadata={**track.metadata, "capture": report})
