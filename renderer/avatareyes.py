"""An avatar's eyes, found as the tools that make avatars name and place them.

Every tool names its eye nodes its own way: three.js's Face Cap head ``grp_eyeLeft`` /
``eyeLeft``, Ready Player Me's bones ``LeftEye`` and meshes ``EyeLeft``, Mixamo's
``mixamorig:LeftEye``, Blender's ``eye.L``, Character Creator's ``CC_Base_L_Eye``, VRoid's
``J_Adj_L_FaceEye``, and others ``Eye_L``, ``L_Eye``, ``lEye``. :func:`find_eyes` reads a
node's name (and its mesh's) as words (``grp_eyeLeft`` -> grp, eye, left; ``CC_Base_L_Eye`` ->
cc, base, l, eye) and takes a node as an eye when one word is ``eye`` (or ``eyeball``) and
none names another part of the eye's surroundings (brow, lash, lid, line, socket, ...).
Among the candidates of a side, the one holding most vertices (skinned to it or in its
subtree) wins, the deeper on a tie; a side word (left / l, right / r) says which side, and
where the words are missing or disagree with the geometry (Face Cap names its eyes as seen
from the camera: ``eyeLeft`` is at -x, the character's right) the geometry decides: glTF's
+x is the character's left (glTF 2.0 sec. 3.4). The VRM humanoid's ``leftEye`` / ``rightEye``
bones and a sidecar's ``bones`` come first, as given.

Where an eye bone does not sit in its eyeball (VRoid's lie medial and 7 cm behind the
irises), :func:`eye_geometry` places the eye at its eyeball instead: the pupil at the front
of the vertices skinned to the eye, the centre of rotation one eyeball radius behind it.

Example
-------
>>> words("grp_eyeLeft"), words("CC_Base_L_Eye"), words("mixamorig:LeftEye")
(['grp', 'eye', 'left'], ['cc', 'base', 'l', 'eye'], ['mixamorig', 'left', 'eye'])
>>> eye_side("J_Adj_L_FaceEye"), eye_side("eye.R"), eye_side("Eyebrow_L"), eye_side("Eye")
('l', 'r', None, '')
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

#: Words that make an "eye" name another part: the brows, lashes, lids and lines around it,
#: the sockets and shadows, the look-at targets and the blendshape-like names of its motion.
NOT_AN_EYE = frozenset(
    "brow brows eyebrow eyebrows lash lashes eyelash eyelashes lid lids eyelid eyelids line "
    "eyeline liner socket shadow highlight hilight white sclera iris cornea target aim look "
    "lookat blink squint wide end top tip tear occlusion".split()
)
_WORD = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|\d+")


def words(name: str) -> list[str]:
    """The lower-case words of a node name: split at punctuation and at case changes."""
    return [w.lower() for w in _WORD.findall(str(name))]


def eye_side(name: str) -> str | None:
    """``"l"`` or ``"r"`` for a name that reads as a left or right eye, ``""`` for an eye of
    no side, None for anything else."""
    ws = words(name)
    if not {"eye", "eyeball", "eyes"} & set(ws) or NOT_AN_EYE & set(ws):
        return None
    left = bool({"left", "l"} & set(ws))
    right = bool({"right", "r"} & set(ws))
    return "l" if left and not right else "r" if right and not left else ""


@dataclass(frozen=True)
class EyeNodes:
    """The node of each eye (``"l"``, ``"r"``: the character's sides) and what was done."""

    nodes: dict[str, int]
    how: str


def find_eyes(
    names: list[str],
    holds: np.ndarray,
    depth: np.ndarray,
    x: np.ndarray,
) -> EyeNodes | None:
    """The two eye nodes among ``names`` (each node's name and its mesh's), or None.

    ``holds`` (k,) counts the vertices each node moves (skinned to it or in its subtree),
    ``depth`` (k,) its depth in the hierarchy, ``x`` (k,) where its eye is across the face.
    """
    sides = {i: eye_side(n) for i, n in enumerate(names)}
    candidates = [i for i, s in sides.items() if s is not None]
    if not candidates:
        return None

    def best(pool: list[int]) -> int:
        return max(pool, key=lambda i: (int(holds[i]), int(depth[i])))

    named = {s: [i for i in candidates if sides[i] == s] for s in ("l", "r")}
    if named["l"] and named["r"]:
        pick = {s: best(named[s]) for s in ("l", "r")}
        how = "by name"
    else:
        # no side words: the two eye nodes that hold most, told apart by where they are
        pool = sorted(candidates, key=lambda i: (-int(holds[i]), -int(depth[i])))
        apart = [i for i in pool if abs(x[i] - x[pool[0]]) > 1e-9]
        if not apart:
            return None
        pick = {"l": pool[0], "r": apart[0]}
        how = "by place"
    if x[pick["l"]] < x[pick["r"]]:  # named as seen from the camera: the geometry decides
        pick = {"l": pick["r"], "r": pick["l"]}
        how += ", sides by place (the names are the camera's left and right)"
    return EyeNodes(pick, how)


def eye_geometry(
    vertices: np.ndarray, pivot: np.ndarray, inter_eye: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """(pupil, centre of rotation) of an eye from the ``vertices`` skinned to it, when its
    bone ``pivot`` lies outside the eyeball (more than an eyeball's width from their middle;
    ``inter_eye`` bounds that width); None when the bone is where the eye is."""
    if len(vertices) < 4:
        return None
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    middle = (lo + hi) / 2.0
    radius = min(float(hi[0] - lo[0]) / 2.0, 0.3 * inter_eye)
    if radius <= 0 or np.linalg.norm(pivot - middle) <= 1.5 * radius:
        return None
    pupil = np.array([middle[0], middle[1], hi[2]])
    return pupil, pupil - np.array([0.0, 0.0, radius])
