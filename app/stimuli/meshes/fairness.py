"""Eyes that stay fair when a face of the pair is a mesh.

A vertex sequence (FaceFormer's, CodeTalker's, ...) has no eyelids facepair can close and often
no eyeballs (BIWI's scans have none; VOCASET's FLAME meshes have them, and FLAME parameters may
turn them). Beside the built-in head, which blinks and looks about as the study's ``eyes`` says
(:mod:`app.stimuli.eyes`), such a face would stare: participants could prefer the face that
blinks whatever its head or mouth does. Le, Ma & Deng (2012, sec. 8) compare conditions whose
eyes are the same; the study's treatment (``mesh_eyes``, :data:`MESH_EYES`) is:

* ``match`` (the default): what a mesh of the study cannot show, no face shows. Every condition's
  eyelid channels (19-22: blinks) are set to 0 (lids open, no blinks) when a condition is a
  mesh, as facepair cannot make a mesh blink; the gaze (23-26) too, unless every mesh condition
  has eyeballs, which then turn with the study's shared gaze like the built-in head's. A blink
  or a glance the mesh file carries in its own vertices is its own and is drawn as given: the
  summary says so;
* ``own``: each face shows what it can: the built-in head keeps the study's blinks and gaze
  beside a mesh that stares (a confound, which the summary's note names).

Example
-------
>>> import numpy as np
>>> from app.stimuli.track import MotionTrack
>>> built_in = MotionTrack.from_channels(30, {19: np.ones(3), 23: np.ones(3), 48: np.ones(3)})
>>> mesh = MotionTrack.zeros(30, 3).replace(metadata={"mesh": {}, "mesh_eyes": False})
>>> out, note = match_mesh_eyes({"a": built_in, "b": mesh}, "match")
>>> out["a"].get(19).tolist(), out["a"].get(23).tolist(), out["a"][48].tolist()
([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
"""

from __future__ import annotations

from collections.abc import Mapping

from app.errors import InputError
from app.stimuli.fap import EYELIDS, GAZE
from app.stimuli.track import MotionTrack

#: The study's treatment of the eyes beside a mesh (see the module's docstring).
MESH_EYES: tuple[str, ...] = ("match", "own")
DEFAULT_MESH_EYES = "match"


def check_mesh_eyes(mode: str) -> None:
    if mode not in MESH_EYES:
        raise InputError(f"expected one of {', '.join(MESH_EYES)}, got {mode!r}", field="mesh_eyes")


def has_eyeballs(track: MotionTrack) -> bool | None:
    """Whether a mesh condition's track has eyeballs (None for a track of FAPs). Read from
    ``metadata["mesh_eyes"]`` when the reader recorded it, else from the mesh."""
    if not isinstance(track.metadata.get("mesh"), Mapping):
        return None
    known = track.metadata.get("mesh_eyes")
    if isinstance(known, bool):
        return known
    from app.stimuli.meshes.source import mesh_of

    seq = mesh_of(track)
    return seq is not None and seq.eyeballs is not None


def match_mesh_eyes(
    tracks: Mapping[str, MotionTrack], mode: str = DEFAULT_MESH_EYES
) -> tuple[dict[str, MotionTrack], str | None]:
    """Every track with the eyes ``mode`` gives them beside the study's meshes, and a line on
    what was done (None when no condition is a mesh)."""
    check_mesh_eyes(mode)
    eyes = {name: has_eyeballs(t) for name, t in tracks.items()}
    meshes = [n for n, e in eyes.items() if e is not None]
    if not meshes:
        return dict(tracks), None
    if mode == "own":
        others = [n for n, e in eyes.items() if e is None]
        note = f"mesh_eyes = 'own': {', '.join(meshes)} cannot blink" + (
            f" beside {', '.join(others)}, which blink: a confound" if others else ""
        )
        return dict(tracks), note
    off = set(EYELIDS)
    eyeless = [n for n in meshes if not eyes[n]]
    if eyeless:
        off |= set(GAZE)
    out = {}
    for name, t in tracks.items():
        zeroed = {c: t.get(c) * 0.0 for c in off if c in t.channels}
        out[name] = t.with_channels(zeroed) if zeroed else t
    what = "no blinks and no gaze" if eyeless else "no blinks (the gaze shared)"
    why = (
        f"{', '.join(eyeless)} has no eyeballs"
        if eyeless
        else "a mesh has no eyelids facepair can close"
    )
    note = (
        f"mesh_eyes = 'match': {what} in any condition, as {why}; motion of the eyes in a "
        "mesh file's own vertices is drawn as given"
    )
    return out, note
