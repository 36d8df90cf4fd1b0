"""A face whose vertices are given per frame: the mesh sequence and its timeline.

A :class:`MeshSequence` is what every reader of :mod:`app.stimuli.meshes` produces and what the
renderer draws (:mod:`renderer.meshface`): a template (any topology), one position per vertex
and frame in metres and facepair's axes (+x the face's own left, +y up, +z forward: FLAME's, and
the projects' renderers look down -z at VOCASET and BIWI alike), the head held still. The head's
turn is not in the vertices but in the condition's head channels (FAPs 48-50,
:func:`rotation_to_head_faps`), so that the study's posture treatment applies to a mesh as to any
face (:mod:`app.stimuli.posture`); a rigid turn found in the vertices is taken out into them
(:func:`stabilise`).

:func:`sample` reads the sequence at the times of another timeline (a clip's frames), linearly
between frames and holding the first and last frame outside it, as
:func:`app.stimuli.track.align_to_features` does for tracks.

A generated condition's mesh is written beside its ``.fap`` as a *mesh bundle*
(``<name>.mesh.npz``, :func:`write_bundle`), already on the track's timeline, so a render worker
needs neither the original files nor a FLAME model.

Example
-------
>>> import numpy as np
>>> seq = MeshSequence(np.zeros((3, 3)), np.array([[0, 1, 2]]), np.arange(18.0).reshape(2, 3, 3),
...                    fps=10.0, label="a.npy")
>>> sample(seq, 3, 20.0)[:, 0, 0].tolist()
[0.0, 4.5, 9.0]
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.errors import InputError
from app.stimuli.fap import AU_RADIANS, GAZE, HEAD_PITCH, HEAD_ROLL, HEAD_YAW

#: Format tag of a mesh bundle.
BUNDLE_FORMAT = "facepair-mesh/1"
#: A rigid turn of the upper head smaller than this (degrees) in every frame is no head motion.
STILL_TURN_DEG = 0.5


@dataclass(eq=False)
class MeshSequence:
    """A mesh sequence (see the module's docstring).

    template : (V, 3) float64, metres.
    triangles : (F, 3) int32.
    frames : (T, V, 3) float32, metres, the head still.
    fps : the frames' rate.
    label : the file it came from, for messages.
    units : the unit the file was in (:data:`app.stimuli.meshes.vertexfile.UNITS`).
    lips, upper : vertex indices a region file named (None: found by the renderer and the
        metrics, :mod:`app.stimuli.meshes.regions`).
    eyeballs : (left, right) vertex indices, or None for a mesh without eyes.
    head_weights : (V,) how far each vertex follows the head's turn (FLAME: its skinning to
        the neck and above), or None: all of it.
    pivot : the head's pivot (FLAME's neck joint), or None: estimated by the renderer.
    kind : ``"vertices"`` or ``"flame"``.
    notes : what was inferred, a line each.
    """

    template: np.ndarray
    triangles: np.ndarray
    frames: np.ndarray
    fps: float
    label: str
    units: str = "m"
    lips: np.ndarray | None = None
    upper: np.ndarray | None = None
    eyeballs: tuple[np.ndarray, np.ndarray] | None = None
    head_weights: np.ndarray | None = None
    pivot: np.ndarray | None = None
    kind: str = "vertices"
    notes: list[str] = field(default_factory=list)

    @property
    def n_frames(self) -> int:
        return int(self.frames.shape[0])

    @property
    def n_vertices(self) -> int:
        return int(self.template.shape[0])

    @property
    def duration(self) -> float:
        return self.n_frames / self.fps

    def digest(self) -> str:
        """SHA-256 of everything that changes how the sequence renders (cached)."""
        cached = self.__dict__.get("_digest")
        if cached is None:
            h = hashlib.sha256(f"{self.fps!r}|{self.kind}|{self.frames.shape}".encode())
            for arr in (self.template, self.triangles, self.frames):
                h.update(np.ascontiguousarray(arr).tobytes())
            for part in (self.lips, self.upper, self.head_weights, self.pivot):
                h.update(b"-" if part is None else np.ascontiguousarray(part).tobytes())
            for eye in self.eyeballs or ():
                h.update(np.ascontiguousarray(eye).tobytes())
            cached = self.__dict__["_digest"] = h.hexdigest()
        return cached


def sample(seq: MeshSequence, n_frames: int, fps: float, offset: float = 0.0) -> np.ndarray:
    """``(n_frames, V, 3)`` float32: the sequence at times ``i / fps - offset`` (``offset``:
    seconds the sequence started after the clip), linear between its frames, its first and last
    frame held outside them."""
    t = np.arange(n_frames) / float(fps) - offset
    u = np.clip(t * seq.fps, 0.0, seq.n_frames - 1)
    i0 = np.floor(u).astype(np.int64)
    i1 = np.minimum(i0 + 1, seq.n_frames - 1)
    a = (u - i0).astype(np.float32)[:, None, None]
    f = seq.frames
    if not a.any():
        return f[i0].copy()
    return f[i0] * (1.0 - a) + f[i1] * a


def rotation_to_head_faps(rot: np.ndarray) -> np.ndarray:
    """Head FAPs (pitch 48, yaw 49, roll 50; AU) of rotations ``(T, 3, 3)``: the angles whose
    product ``R_y(yaw) R_x(pitch) R_z(roll)`` is the rotation, the order in which
    :func:`renderer.deform.fap_rotation` composes the head's turns."""
    r = np.asarray(rot, dtype=np.float64)
    pitch = np.arcsin(np.clip(-r[:, 1, 2], -1.0, 1.0))
    yaw = np.arctan2(r[:, 0, 2], r[:, 2, 2])
    roll = np.arctan2(r[:, 1, 0], r[:, 1, 1])
    return np.column_stack([pitch, yaw, roll]) / AU_RADIANS


def rotation_to_gaze_faps(rot: np.ndarray) -> np.ndarray:
    """Yaw and pitch (AU) of eye rotations ``(T, 3, 3)`` as ``R_y(yaw) R_x(pitch)`` (the
    eyes' roll, which the FAPs do not have, is left out)."""
    r = np.asarray(rot, dtype=np.float64)
    pitch = np.arcsin(np.clip(-r[:, 1, 2], -1.0, 1.0))
    yaw = np.arctan2(r[:, 0, 2], r[:, 2, 2])
    return np.column_stack([yaw, pitch]) / AU_RADIANS


def head_channels(rot: np.ndarray) -> dict[int, np.ndarray]:
    """``{48: pitch, 49: yaw, 50: roll}`` columns (AU) of head rotations ``(T, 3, 3)``."""
    faps = rotation_to_head_faps(rot)
    return {HEAD_PITCH: faps[:, 0], HEAD_YAW: faps[:, 1], HEAD_ROLL: faps[:, 2]}


def gaze_channels(left: np.ndarray, right: np.ndarray) -> dict[int, np.ndarray]:
    """Gaze columns (FAPs 23-26, AU) of the left and right eyes' rotations ``(T, 3, 3)``."""
    yaw_l, yaw_r, pitch_l, pitch_r = GAZE
    lf, rf = rotation_to_gaze_faps(left), rotation_to_gaze_faps(right)
    return {yaw_l: lf[:, 0], yaw_r: rf[:, 0], pitch_l: lf[:, 1], pitch_r: rf[:, 1]}


def rigid_fit(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame the rotation ``R`` and translation ``t`` with ``target ~ R source + t``, least
    squares (Kabsch 1976), for ``source`` (K, 3) and ``target`` (T, K, 3)."""
    s = np.asarray(source, dtype=np.float64)
    q = np.asarray(target, dtype=np.float64)
    cs, cq = s.mean(axis=0), q.mean(axis=1)
    h = np.einsum("ka,tkb->tab", s - cs, q - cq[:, None, :])
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(np.einsum("tab,tbc->tac", u, vt)))
    fix = np.ones((len(q), 3))
    fix[:, 2] = d
    rot = np.einsum("tba,tb,tcb->tac", vt, fix, u)
    return rot, cq - np.einsum("tab,b->ta", rot, cs)


def stabilise(
    template: np.ndarray, frames: np.ndarray, stable: np.ndarray
) -> tuple[np.ndarray, np.ndarray | None]:
    """``frames`` with the rigid head motion of the ``stable`` vertices taken out, and that
    motion's rotations ``(T, 3, 3)``; unchanged (and None) where it turns less than
    :data:`STILL_TURN_DEG` and travels less than a millimetre in every frame, as the projects'
    registered sequences do."""
    rot, trans = rigid_fit(template[stable], frames[:, stable])
    angle = np.degrees(np.arccos(np.clip((np.trace(rot, axis1=1, axis2=2) - 1) / 2, -1, 1)))
    if angle.max(initial=0.0) < STILL_TURN_DEG and np.abs(trans).max(initial=0.0) < 1e-3:
        return frames, None
    back = np.einsum("tba,tvb->tva", rot, frames.astype(np.float64) - trans[:, None, :])
    return back.astype(np.float32), rot


def write_bundle(seq: MeshSequence, path: str | Path) -> Path:
    """Write ``seq`` as a mesh bundle (``numpy.savez_compressed``; see the module's docstring)."""
    arrays: dict[str, np.ndarray] = {
        "format": np.array(BUNDLE_FORMAT),
        "template": seq.template.astype(np.float64),
        "triangles": seq.triangles.astype(np.int32),
        "frames": seq.frames.astype(np.float32),
        "fps": np.array(float(seq.fps)),
        "label": np.array(seq.label),
        "units": np.array(seq.units),
        "kind": np.array(seq.kind),
    }
    for key in ("lips", "upper", "head_weights", "pivot"):
        value = getattr(seq, key)
        if value is not None:
            arrays[key] = np.asarray(value)
    if seq.eyeballs is not None:
        arrays["eyeball_l"], arrays["eyeball_r"] = seq.eyeballs
    out = Path(path)
    with open(out, "wb") as fh:
        np.savez_compressed(fh, **arrays)  # type: ignore[arg-type]
    return out


def read_bundle(path: str | Path) -> MeshSequence:
    """A mesh bundle written by :func:`write_bundle`."""
    p = Path(path)
    try:
        with np.load(p, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except FileNotFoundError:
        raise InputError("the mesh bundle of this track is missing", path=p) from None
    except (OSError, ValueError) as exc:
        raise InputError(f"not a readable mesh bundle ({exc})", path=p) from None
    if str(data.get("format", "")) != BUNDLE_FORMAT:
        raise InputError(f"not a {BUNDLE_FORMAT} bundle", path=p)
    eyes = None
    if "eyeball_l" in data and "eyeball_r" in data:
        eyes = (data["eyeball_l"].astype(np.int64), data["eyeball_r"].astype(np.int64))
    return MeshSequence(
        template=data["template"].astype(np.float64),
        triangles=data["triangles"].astype(np.int32),
        frames=data["frames"].astype(np.float32),
        fps=float(data["fps"]),
        label=str(data["label"]),
        units=str(data["units"]),
        lips=data["lips"].astype(np.int64) if "lips" in data else None,
        upper=data["upper"].astype(np.int64) if "upper" in data else None,
        eyeballs=eyes,
        head_weights=data.get("head_weights"),
        pivot=data.get("pivot"),
        kind=str(data["kind"]),
    )
