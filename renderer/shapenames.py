"""Blendshape names in every convention avatars use, matched to the ARKit shape they stand for.

The same 52 ARKit shapes are spelled differently by each tool:

=========================== ======================= ========================================
convention                  example                 source
=========================== ======================= ========================================
ARKit's own                 ``eyeBlinkLeft``        Apple, ``ARFaceAnchor.BlendShapeLocation``
Live Link Face (PascalCase) ``EyeBlinkLeft``        Epic's CSV header (the capture import)
Face Cap (``_L`` / ``_R``)  ``eyeBlink_L``          Bannaflak Face Cap's blendshape list
prefixed (Blender, Maya)    ``blendShape1.jawOpen`` a mesh or node name before the dot
Blender side suffix         ``browDown.L``          Blender's ``.L`` / ``.R`` naming
VRM 0.x blendShapeMaster    ``blink_l``, ``a``      VRM 0.x spec, ``BlendShapePresetName``
VRM 1.0 expressions         ``blinkLeft``, ``aa``   VRM 1.0 spec, ``VRMC_vrm.expressions``
=========================== ======================= ========================================

:func:`canonical` maps a name to a key shared by the first five (lower case, punctuation out, a
trailing side letter spelt out), so ``eyeBlink_L`` and ``EyeBlinkLeft`` meet. VRM presets are
not ARKit shapes; :data:`VRM_PRESETS` says which ARKit shapes each may stand in for when the
avatar has no shape of that name (VRoid's "perfect sync" avatars carry ARKit-named custom
expressions as well, which match by name). :func:`arkit_spelling` is ARKit's own spelling of
a table name, what ``facepair face export`` writes.

>>> canonical("eyeBlink_L") == canonical("EyeBlinkLeft") == canonical("blendShape1.eyeBlinkLeft")
True
>>> canonical("browDown.R") == canonical("BrowDownRight")
True
>>> arkit_spelling("BrowInnerUp")
'browInnerUp'
"""

from __future__ import annotations

import re

#: VRM expression preset (canonical) -> the ARKit shapes (table spelling) it stands in for; a
#: preset standing for several takes the mean of their weights. Visemes after the VRM 1.0
#: spec's descriptions: aa an open jaw, oh rounded open lips, ou puckered lips, ee spread lips.
VRM_PRESETS: dict[str, tuple[str, ...]] = {
    "blinkleft": ("EyeBlinkLeft",),
    "blinkl": ("EyeBlinkLeft",),
    "blinkright": ("EyeBlinkRight",),
    "blinkr": ("EyeBlinkRight",),
    "blink": ("EyeBlinkLeft", "EyeBlinkRight"),
    "aa": ("JawOpen",),
    "a": ("JawOpen",),
    "oh": ("MouthFunnel",),
    "o": ("MouthFunnel",),
    "ou": ("MouthPucker",),
    "u": ("MouthPucker",),
    "ee": ("MouthStretchLeft", "MouthStretchRight"),
    "e": ("MouthStretchLeft", "MouthStretchRight"),
}

_SIDE = re.compile(r"(?:[_.\s-]|(?<=[a-z]))([LR])$")


def canonical(name: str) -> str:
    """The convention-free key of a blendshape name (module docstring).

    Order matters: a side suffix (``_L``, ``.R``, ``-L``, or a capital L/R after a lower-case
    letter, as in ``eyeBlinkL``) is spelt out first, then a prefix up to the last dot is dropped,
    then case and punctuation.
    """
    text = str(name).strip()
    side = _SIDE.search(text)
    if side:
        text = text[: side.start()] + ("Left" if side.group(1) == "L" else "Right")
    text = text.rsplit(".", 1)[-1]
    return re.sub(r"[^a-z0-9]", "", text.lower())


def arkit_spelling(name: str) -> str:
    """ARKit's own spelling (``jawOpen``) of a table name in Live Link Face's (``JawOpen``)."""
    return name[:1].lower() + name[1:]
