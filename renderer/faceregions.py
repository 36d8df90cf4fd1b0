"""What the mosaic of each face of a clip needs: the region its mouth moves through, the
vertices it never covers, and a mesh face's vertices at the clip's frames.

A pair of one kind of face (the built-in head, an avatar) shares one region, from both faces'
tracks (:func:`renderer.mouthregion.motion_envelope`); a mesh's region comes from its own frames
(:func:`renderer.meshmosaic.mesh_envelope`), as a mesh beside another face is drawn by a canvas of
its own (:mod:`renderer.pipeline`).

Example
-------
>>> from renderer.headmodel import builtin_face
>>> from renderer.pipeline import rig_for
>>> import numpy as np
>>> rig = rig_for(builtin_face())
>>> len(never_covered(rig)) > 400
True
"""

from __future__ import annotations

import numpy as np

from app.stimuli.meshes.sequence import sample
from app.stimuli.track import MotionTrack
from renderer.deform import Rig
from renderer.face import Face
from renderer.meshface import MeshFace, MeshRig
from renderer.meshmosaic import mesh_envelope
from renderer.mouthregion import MotionEnvelope, motion_envelope, upper_face


def never_covered(rig: Rig) -> np.ndarray:
    """The vertices no mosaic block covers: the eyes, lids and brows (:func:`upper_face`;
    a mesh's: :attr:`renderer.meshface.MeshFace.upper_face`)."""
    if isinstance(rig, MeshRig):
        return np.asarray(rig.face.upper_face, dtype=int)  # type: ignore[attr-defined]
    return upper_face(rig)


def face_envelopes(
    faces: list[Face],
    rigs: list[Rig],
    dense: list[np.ndarray],
    mesh_frames: list[np.ndarray | None],
) -> list[MotionEnvelope]:
    """Each face's mouth envelope: a mesh's from its own frames; a FAP face's from the tracks
    of every face of its kind, so both faces of a pair of one kind get the same region."""
    out: list[MotionEnvelope] = []
    shared: dict[str, MotionEnvelope] = {}
    for k, face in enumerate(faces):
        frames = mesh_frames[k]
        rig = rigs[k]
        if frames is not None:
            assert isinstance(rig, MeshRig)
            out.append(mesh_envelope(rig, frames))
            continue
        key = face.content_hash()
        if key not in shared:
            alike = [dense[j] for j, f in enumerate(faces) if f.content_hash() == key]
            shared[key] = motion_envelope(rig, alike)
        out.append(shared[key])
    return out


def mesh_frames_of(track: MotionTrack, face: Face) -> np.ndarray | None:
    """A mesh face's vertices at each frame of ``track``, None for a FAP face."""
    if not isinstance(face, MeshFace) or face.sequence is None:
        return None
    offset = float(track.metadata.get("offset_s", 0.0) or 0.0)
    return sample(face.sequence, track.n_frames, track.fps, offset)
