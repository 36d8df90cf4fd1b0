"""FAP deformation of a :class:`~renderer.face.Face`: raised-cosine zones, jaw, eyelids, eyes, head.

Follows the MPEG-4 FBA deformation as the open player Xface implements it (project reference
``mpeg4-fap``). Each FAP's feature point, direction, FAPU, rotation axis and side are read from
the FAP table (:mod:`app.stimuli.fap`), so this module states only how the face moves. The
translational FAPs (lips, chin, brows) move raised-cosine zones about their feature points
(:mod:`renderer.fapzones`, where the zones and their sources are); the normals of the skin a
part (the mouth, the brows) moves are recomputed when it moves
(:class:`renderer.skin.SkinPart`).

Rotations:

* the jaw (3) about the hinge axis so that the chin moves by value * FAPU, with thrust (14)
  and shift (15) as translations, weighted per vertex;
* the eyelids (19-22): each lid turns about its eye centre so that its margin moves by
  value * FAPU, weighted from margin to root;
* the eyeballs (23-26) about their centres and the head (48-50) about feature point 7.1,
  blended into the neck by the ``head`` weight.

The head and eye rotations are returned as matrices; :meth:`Rig.posed` applies them, with the
rest of the deformation, on the vertices (vectorised numpy; about a millisecond a face), so the
GL side draws final world-space vertices with no per-face uniforms (on a software rasteriser a
uniform change between the two faces of a frame costs more than the whole pose).

Example
-------
>>> import numpy as np
>>> from renderer.headmodel import builtin_face
>>> rig = Rig(builtin_face())
>>> faps = np.zeros(68); faps[31 - 1] = 200.0   # raise the left inner eyebrow
>>> frame = rig.deform(faps)
>>> i = rig.face.fp_vertices["4.1"]
>>> bool(frame.positions[i, 1] > rig.face.vertices[i, 1])
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.stimuli.fap import (
    AU_RADIANS,
    AXIS,
    DIRECTION,
    EYEBROW_RAISE,
    EYEBROWS,
    EYELIDS,
    FAPS,
    FEATURE_POINT,
    GAZE,
    HEAD,
    HEAD_PITCH,
    HEAD_ROLL,
    HEAD_YAW,
    JAW_LIPS,
    OPEN_JAW,
    SHIFT_JAW,
    SIDE,
    THRUST_JAW,
    fapu_values,
)
from renderer.face import Face
from renderer.fapzones import direction, on_side, translation_basis
from renderer.rigweights import derive_weights
from renderer.skin import SkinPart, one_ring

#: The FAPs of the jaw and lips (set to zero for the mouth at rest that the mosaic shows).
MOUTH_FAPS: tuple[int, ...] = tuple(sorted(JAW_LIPS))

#: Every FAP the deformation moves (the groups the stimulus engine produces).
SUPPORTED_FAPS: tuple[int, ...] = tuple(sorted(JAW_LIPS + EYELIDS + GAZE + EYEBROWS + HEAD))


_IDENTITY = np.eye(4)
_IDENTITY.flags.writeable = False
MOUTH_FAPS_INDEX = np.array(MOUTH_FAPS) - 1


#: The rotation FAPs of each eyeball (yaw, then pitch) and of the head (yaw, pitch, roll), in
#: the order their rotations compose.
EYE_TURNS = {
    side: tuple(sorted(on_side(GAZE, side), key=lambda f: AXIS[f] != "y")) for side in ("l", "r")
}
HEAD_TURNS = (HEAD_YAW, HEAD_PITCH, HEAD_ROLL)


def fap_rotation(faps: np.ndarray, turns: tuple[int, ...]) -> np.ndarray:
    """3x3 product of the rotations of the FAPs ``turns`` (AU, about their table axes), in
    that order; ``faps`` holds 68 values, FAP k at k-1."""
    rot = rotation(AXIS[turns[0]], faps[turns[0] - 1] * AU_RADIANS)
    for t in turns[1:]:
        rot = rot @ rotation(AXIS[t], faps[t - 1] * AU_RADIANS)
    return rot


def rotation(axis: str, angle: float) -> np.ndarray:
    """3x3 right-handed rotation about ``x``, ``y`` or ``z``."""
    c, s = np.cos(angle), np.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def about(rot: np.ndarray, pivot: np.ndarray) -> np.ndarray:
    """4x4 matrix rotating by ``rot`` about ``pivot``."""
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = pivot - rot @ pivot
    return m


@dataclass
class FaceFrame:
    """One deformed face: vertex positions/normals before the rigid head and eye rotations."""

    positions: np.ndarray  # float32 (n, 3)
    normals: np.ndarray  # float32 (n, 3)
    head: np.ndarray  # 4x4 head rotation about 7.1
    eye_l: np.ndarray  # 4x4 rotations about the eye centres
    eye_r: np.ndarray


class Rig:
    """The deformation of one face, precomputed once: zones, weights, pivots.

    What counts as the mouth's motion for the mosaic (:mod:`renderer.mouthregion`): a vertex
    moved by more than ``motion_tolerance`` or whose normal turns by more than
    ``normal_tolerance``, no higher than ``mouth_ceiling`` (None: anywhere). The built-in head
    counts every change; an avatar's sculpted shapes move skin up to the brows by fractions of
    a pixel (:class:`renderer.avatar.AvatarRig`).
    """

    motion_tolerance: float = 0.0
    normal_tolerance: float = 0.0
    mouth_ceiling: float | None = None

    def __init__(self, face: Face) -> None:
        self.face = face
        self.v0 = face.vertices.astype(np.float32)
        self.n0 = face.normals()
        self.weights = derive_weights(face)
        fu = fapu_values(face.fapu)
        self.fapu = fu
        fp = face.feature_points
        columns, self.brow_lower_limit = translation_basis(face, self.weights, fu)
        self.basis_faps = np.array(sorted(columns))
        self._brow_columns = np.isin(self.basis_faps, EYEBROW_RAISE)
        stacked = np.stack([columns[f] for f in self.basis_faps])  # (k, n, 3)
        of_mouth = np.isin(self.basis_faps, MOUTH_FAPS)
        self.mouth, self.brows = (
            SkinPart(np.flatnonzero(cols), stacked, face.triangles)
            for cols in (of_mouth, ~of_mouth)
        )

        hinge = face.hinge()
        self.hinge = hinge
        chin = fp[FEATURE_POINT[OPEN_JAW]]
        lever = max(chin[2] - hinge[2], 0.3 * float(np.linalg.norm(chin - hinge)))
        self.jaw_rad_per_unit = fu[FAPS[OPEN_JAW].unit] / lever
        #: jaw shift (to the right) and thrust (forward) per unit FAP value
        self.jaw_shift = {f: direction(f) * fu[FAPS[f].unit] for f in (SHIFT_JAW, THRUST_JAW)}
        self.jaw_zone = np.flatnonzero(self.weights["jaw"] > 1e-6)
        self.jaw_w = self.weights["jaw"][self.jaw_zone]
        self.lids = []
        for fap in EYELIDS:
            side, upper = SIDE[fap], DIRECTION[fap][1] < 0
            layer = self.weights[f"eyelid_{'upper' if upper else 'lower'}_{side}"]
            zone = np.flatnonzero(layer > 1e-6)
            centre = face.eye_centre(side)
            margin = fp[FEATURE_POINT[fap]]
            r = max(float(np.linalg.norm(margin - centre)), 1e-9)
            sign = -direction(fap)[1]  # a positive turn about x moves the margin down
            self.lids.append((fap, zone, layer[zone], centre, sign * fu[FAPS[fap].unit] / r))
        self._set_pose({s: face.eye_centre(s) for s in ("l", "r")})
        #: the vertices only the jaw and lip FAPs change (None: other FAPs reach them too)
        self.rest_mouth_vertices = self._mouth_apart()

    def _set_pose(self, eye_centres: dict[str, np.ndarray]) -> None:
        """What :meth:`posed` needs: eye pivots and vertices, the head pivot, and the vertices
        the head leaves still or blends (by the ``head`` weight)."""
        face = self.face
        self.eye_centres = eye_centres
        self.eye_vertices = {s: np.asarray(face.groups[f"eyeball_{s}"]) for s in ("l", "r")}
        self.pivot = face.pivot()
        head_w = self.weights["head"].astype(np.float32)
        self._still = np.flatnonzero(head_w <= 0.0)
        self._blend = np.flatnonzero((head_w > 0.0) & (head_w < 1.0))
        self._blend_w = head_w[self._blend][:, None]

    def deform(self, faps: np.ndarray) -> FaceFrame:
        """Deform the neutral face by one frame of FAPs (68 values in FAPU, FAP k at k-1)."""
        f = np.asarray(faps, dtype=np.float64)
        pos = self.v0.copy()
        nrm = self.n0.copy()
        coeff = f[self.basis_faps - 1]
        lower = self._brow_columns & (coeff < 0)  # brows lower with room to spare: saturate
        if lower.any():
            limit = max(self.brow_lower_limit, 1e-9)
            coeff = np.where(lower, limit * np.tanh(coeff / limit), coeff)
        coeff = coeff.astype(np.float32)
        moved = [part for part in (self.mouth, self.brows) if part.move(coeff, pos)]
        for part in moved:
            part.shade(pos, nrm)
        jaw, thrust, shift = f[OPEN_JAW - 1], f[THRUST_JAW - 1], f[SHIFT_JAW - 1]
        if jaw > 0.0 or thrust > 0.0 or shift:
            jaw_open = max(jaw, 0.0) * self.jaw_rad_per_unit
            move = shift * self.jaw_shift[SHIFT_JAW] + max(thrust, 0.0) * self.jaw_shift[THRUST_JAW]
            self._rotate_x(pos, nrm, self.jaw_zone, self.jaw_w * jaw_open, self.hinge)
            pos[self.jaw_zone] += (self.jaw_w[:, None] * move).astype(np.float32)
        for fap, zone, w, centre, rad_per_unit in self.lids:
            if f[fap - 1]:
                self._rotate_x(pos, nrm, zone, w * f[fap - 1] * rad_per_unit, centre)
        eyes = {"l": _IDENTITY, "r": _IDENTITY}  # (shared: posed skips eyes at rest)
        for side, turns in EYE_TURNS.items():
            if any(f[t - 1] for t in turns):
                eyes[side] = about(fap_rotation(f, turns), self.eye_centres[side])
        head = fap_rotation(f, HEAD_TURNS)
        return FaceFrame(pos, nrm, about(head, self.pivot), eyes["l"], eyes["r"])

    @staticmethod
    def _rotate_x(
        pos: np.ndarray, nrm: np.ndarray, zone: np.ndarray, angle: np.ndarray, pivot: np.ndarray
    ) -> None:
        """Rotate ``zone`` vertices about the x-parallel axis through ``pivot``, per-vertex angle
        (positive moves points in front of the axis down)."""
        c, s = np.cos(angle), np.sin(angle)
        y = pos[zone, 1] - pivot[1]
        z = pos[zone, 2] - pivot[2]
        pos[zone, 1] = pivot[1] + c * y - s * z
        pos[zone, 2] = pivot[2] + s * y + c * z
        ny, nz = nrm[zone, 1].copy(), nrm[zone, 2].copy()
        nrm[zone, 1] = c * ny - s * nz
        nrm[zone, 2] = s * ny + c * nz

    def posed(self, frame: FaceFrame) -> tuple[np.ndarray, np.ndarray]:
        """World-space ``(positions, unit normals)`` of ``frame``, two contiguous float32 (n, 3).

        The eyeballs turn about their centres, then the head turns about 7.1, blended per
        vertex by the ``head`` weight (1 on the head, fading to 0 down the neck). Only the
        blended vertices need their normals renormalised: rotations keep unit length.
        """
        pos, nrm = frame.positions, frame.normals
        if self._eyes_turned(frame):
            pos, nrm = pos.copy(), nrm.copy()
            for side, m in (("l", frame.eye_l), ("r", frame.eye_r)):
                idx = self.eye_vertices[side]
                rot = m[:3, :3].astype(np.float32)
                pos[idx] = pos[idx] @ rot.T + m[:3, 3].astype(np.float32)
                nrm[idx] = nrm[idx] @ rot.T
        rot = frame.head[:3, :3].astype(np.float32)
        moved = pos @ rot.T
        moved += frame.head[:3, 3].astype(np.float32)
        turned = nrm @ rot.T
        still, blend = self._still, self._blend
        moved[still], turned[still] = pos[still], nrm[still]
        if len(blend):
            moved[blend], turned[blend] = self._bend(frame.head, pos[blend], nrm[blend])
        return moved, turned

    def _bend(
        self, head: np.ndarray, pos: np.ndarray, nrm: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The blended vertices (a neck) turned by their weight's share of the head's turn
        about the pivot: ``w`` times its angle about its axis (Rodrigues' formula), so a
        ring half way down the neck turns half as far and the neck bends with the head; a
        blend of positions instead sheared it and left it standing upright under a rolled
        head."""
        rot = head[:3, :3]
        angle = float(np.arccos(np.clip((np.trace(rot) - 1.0) / 2.0, -1.0, 1.0)))
        if angle < 1e-9:
            return pos, nrm
        axis = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]])
        axis = axis / max(float(np.linalg.norm(axis)), 1e-12)
        theta = (self._blend_w * angle).astype(np.float32)  # (n, 1)
        c, s = np.cos(theta), np.sin(theta)
        k = axis.astype(np.float32)

        def turn(v: np.ndarray) -> np.ndarray:
            return v * c + np.cross(k, v) * s + np.outer(v @ k, k) * (1.0 - c)

        pivot = self.pivot.astype(np.float32)
        return turn(pos - pivot) + pivot, turn(nrm)

    def mouth_at_rest(self, frame: FaceFrame, faps: np.ndarray) -> FaceFrame:
        """``frame`` (deformed from ``faps``) as it would be with the jaw and lip FAPs at zero:
        the face the mouth mosaic takes its colours from (:mod:`renderer.mosaic`).

        Equal to deforming ``faps`` with :data:`MOUTH_FAPS` at zero. Where nothing else moves
        the triangles the mouth moves (the built-in head), their vertices are simply put back
        at rest, without a second deformation.
        """
        if self.rest_mouth_vertices is None:
            rest = np.array(faps, dtype=np.float64)
            rest[MOUTH_FAPS_INDEX] = 0.0
            return self.deform(rest)
        idx = self.rest_mouth_vertices
        pos, nrm = frame.positions.copy(), frame.normals.copy()
        pos[idx], nrm[idx] = self.v0[idx], self.n0[idx]
        return FaceFrame(pos, nrm, frame.head, frame.eye_l, frame.eye_r)

    def _mouth_apart(self) -> np.ndarray | None:
        """The vertices whose position or normal only the jaw and lip FAPs change (the mouth
        parts and their one-ring), or None if other FAPs move any of their triangles."""
        triangles, n = self.face.triangles, self.face.n_vertices
        mouth = one_ring(triangles, np.union1d(self.mouth.zone, self.jaw_zone), n)
        others = np.concatenate(
            [self.brows.zone, *(zone for _, zone, *_ in self.lids), *self.eye_vertices.values()]
        )
        return None if np.isin(mouth, one_ring(triangles, others, n)).any() else mouth

    @staticmethod
    def _eyes_turned(frame: FaceFrame) -> bool:
        if frame.eye_l is _IDENTITY and frame.eye_r is _IDENTITY:
            return False
        return not (
            np.array_equal(frame.eye_l, _IDENTITY) and np.array_equal(frame.eye_r, _IDENTITY)
        )

    def world_points(self, frame: FaceFrame, names: tuple[str, ...]) -> np.ndarray:
        """Deformed positions of mesh feature points after the head rotation, (k, 3)."""
        idx = np.array([self.face.fp_vertices[n] for n in names])
        p = frame.positions[idx].astype(np.float64)
        ph = p @ frame.head[:3, :3].T + frame.head[:3, 3]
        w = self.weights["head"][idx][:, None]
        return p + w * (ph - p)
