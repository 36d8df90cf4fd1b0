"""FAP deformation of a :class:`~renderer.face.Face`: raised-cosine zones, jaw, eyelids, eyes, head.

Follows the MPEG-4 FBA deformation as the open player Xface implements it (project reference
``mpeg4-fap``): a vertex at distance ``d`` from a FAP's feature point moves by
``w(d) * value * FAPU`` along the FAP's direction, with the raised-cosine influence
``w(d) = (1 + cos(pi d / dmax)) / 2`` for ``d < dmax``. Each FAP's feature point, direction,
FAPU, rotation axis and side are read from the FAP table (:mod:`app.stimuli.fap`), so this
module states only how the face moves. Translational FAPs:

* lips, inner (4-13) and outer (51-60), push (16, 17) and chin (18), with the upper- and
  lower-lip FAPs kept to their own lip (Parke's unconnected lips, thesis sec. 2.1.2);
* eyebrows, raise (31-36) and squeeze (37/38). The brows use a smooth field separable in width
  and height (:func:`renderer.browfield.brow_field`) instead of radial zones, and a lowered
  brow saturates before the skin between brow and lid would fold.

The normals of the skin a part (the mouth, the brows) moves are recomputed when it moves
(:class:`renderer.skin.SkinPart`).

Zones along one lip or brow reach exactly to the neighbouring feature point, so each feature
point moves by value * FAPU and equal values move the lip or brow uniformly; an inner/outer lip
pair shares a vertex by proximity (the nearer feature point wins).

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
    EYEBROW_SQUEEZE,
    EYEBROWS,
    EYELIDS,
    FAPS,
    FEATURE_POINT,
    GAZE,
    HEAD,
    HEAD_PITCH,
    HEAD_ROLL,
    HEAD_YAW,
    INNER_LIPS,
    JAW_LIPS,
    LIP_PUSH_CHIN,
    OPEN_JAW,
    OUTER_LIPS,
    SHIFT_JAW,
    SIDE,
    THRUST_JAW,
    fapu_values,
)
from renderer.browfield import BROW_LOWER_ROOM, BROW_RAMP_END, brow_field
from renderer.face import Face
from renderer.rigweights import derive_weights
from renderer.skin import SkinPart, one_ring

#: Outer lip FAP of each inner one, and outer lip feature point of each inner one.
_OUTER_FAP = dict(zip(INNER_LIPS, OUTER_LIPS, strict=True))
_OUTER_OF = {FEATURE_POINT[i]: FEATURE_POINT[o] for i, o in _OUTER_FAP.items()}
#: Lip zones whose weights are normalised together (vertical motion of one lip): the feature
#: points along each inner lip, corners included.
_CHAINS = {
    "upper": ("2.2", "2.6", "2.7", "2.4", "2.5"),
    "lower": ("2.3", "2.8", "2.9", "2.4", "2.5"),
}

#: The FAPs of the jaw and lips (set to zero for the mouth at rest that the mosaic shows).
MOUTH_FAPS: tuple[int, ...] = tuple(sorted(JAW_LIPS))

#: Every FAP the deformation moves (the groups the stimulus engine produces).
SUPPORTED_FAPS: tuple[int, ...] = tuple(sorted(JAW_LIPS + EYELIDS + GAZE + EYEBROWS + HEAD))


def _direction(fap: int) -> np.ndarray:
    """The unit vector a positive value of translational ``fap`` moves its feature point."""
    return np.array(DIRECTION[fap])


def _on_side(faps: tuple[int, ...], side: str) -> tuple[int, ...]:
    return tuple(f for f in faps if SIDE.get(f) == side)


def raised_cosine(d: np.ndarray, dmax: float) -> np.ndarray:
    """Xface's influence ``(1 + cos(pi d / dmax)) / 2`` inside ``dmax``, 0 outside."""
    return np.where(d < dmax, 0.5 * (1.0 + np.cos(np.pi * np.minimum(d / dmax, 1.0))), 0.0)


def _chain_weights(v: np.ndarray, points: list[np.ndarray]) -> np.ndarray:
    """Raised-cosine zones along a chain of feature points (a lip, a brow), (k, n).

    Each zone reaches exactly to the nearest other point of the chain, so a feature point
    moves by its own FAP alone (weight 1) and, between two points, the two zones sum to one
    (cos^2 + sin^2): equal values move the chain uniformly.
    """
    pts = np.asarray(points, dtype=np.float64)
    gaps = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    np.fill_diagonal(gaps, np.inf)
    reach = np.maximum(gaps.min(axis=1), 1e-6)
    return np.stack(
        [raised_cosine(np.linalg.norm(v - p, axis=1), r) for p, r in zip(pts, reach, strict=True)]
    )


_IDENTITY = np.eye(4)
_IDENTITY.flags.writeable = False
MOUTH_FAPS_INDEX = np.array(MOUTH_FAPS) - 1


#: The rotation FAPs of each eyeball (yaw, then pitch) and of the head (yaw, pitch, roll), in
#: the order their rotations compose.
EYE_TURNS = {
    side: tuple(sorted(_on_side(GAZE, side), key=lambda f: AXIS[f] != "y")) for side in ("l", "r")
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
        v = face.vertices.astype(np.float64)
        self.v0 = face.vertices.astype(np.float32)
        self.n0 = face.normals()
        self.weights = derive_weights(face)
        fu = fapu_values(face.fapu)
        self.fapu = fu
        fp = face.feature_points
        eyeball = np.zeros(face.n_vertices, bool)
        for side in ("l", "r"):
            eyeball[face.groups[f"eyeball_{side}"]] = True
        mw0, es0 = face.fapu["MW0"], face.fapu["ES0"]

        columns: dict[int, np.ndarray] = {}  # fap -> (n, 3) displacement per unit FAP value
        for name, chain in _CHAINS.items():
            for layer_fps, tag in ((chain, "inner"), (tuple(_OUTER_OF[c] for c in chain), "outer")):
                norm = _chain_weights(v, [fp[c] for c in layer_fps])
                norm *= self.weights[f"{name}_lip"] * ~eyeball
                for fap in INNER_LIPS:  # vertical ones; a corner FAP moves both lips
                    pt, direction = FEATURE_POINT[fap], _direction(fap)
                    if pt not in chain or direction[0] != 0:
                        continue
                    f = fap if tag == "inner" else _OUTER_FAP[fap]
                    w = norm[chain.index(pt)] * self._pair_share(v, pt, tag)
                    columns[f] = columns.get(f, 0) + w[:, None] * direction * fu[FAPS[fap].unit]
        for fap in INNER_LIPS:  # horizontal ones: the corners stretch
            pt, direction = FEATURE_POINT[fap], _direction(fap)
            if direction[0] == 0:
                continue
            for f, p, tag in ((fap, pt, "inner"), (_OUTER_FAP[fap], _OUTER_OF[pt], "outer")):
                w = raised_cosine(np.linalg.norm(v - fp[p], axis=1), 0.5 * mw0) * ~eyeball
                columns[f] = (
                    (w * self._pair_share(v, pt, tag))[:, None] * direction * fu[FAPS[fap].unit]
                )
        for fap in LIP_PUSH_CHIN:  # the chin (2.10) moves with the lower lip
            pt = FEATURE_POINT[fap]
            lip = "upper" if pt in _CHAINS["upper"] else "lower"
            w = raised_cosine(np.linalg.norm(v - fp[pt], axis=1), 0.7 * mw0)
            w = w * self.weights[f"{lip}_lip"] * ~eyeball
            columns[fap] = w[:, None] * _direction(fap) * fu[FAPS[fap].unit]
        self.brow_lower_limit = np.inf  # FAP units: lowering saturates at this
        upper_lid = {SIDE[f]: FEATURE_POINT[f] for f in EYELIDS if DIRECTION[f][1] < 0}
        for side in ("l", "r"):
            faps = _on_side(EYEBROW_RAISE, side)  # inner, middle, outer
            pts = np.array([fp[FEATURE_POINT[f]] for f in faps])
            lid = fp[upper_lid[side]]
            field = brow_field(v, pts, lid, face.fapu["ENS0"]) * ~eyeball
            ens = fu[FAPS[faps[0]].unit]
            room = float(np.min(pts[:, 1] - BROW_RAMP_END * face.fapu["ENS0"] - lid[1]))
            self.brow_lower_limit = min(
                self.brow_lower_limit, BROW_LOWER_ROOM * max(room, 0.0) / 1.5 / ens
            )
            for j, f in enumerate(faps):
                columns[f] = field[j][:, None] * _direction(f) * fu[FAPS[f].unit]
            mask = field.sum(axis=0)
            (f,) = _on_side(EYEBROW_SQUEEZE, side)
            squeeze = (
                raised_cosine(np.linalg.norm(v - fp[FEATURE_POINT[f]], axis=1), 0.5 * es0) * mask
            )
            columns[f] = squeeze[:, None] * _direction(f) * fu[FAPS[f].unit]

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
        self.jaw_shift = {f: _direction(f) * fu[FAPS[f].unit] for f in (SHIFT_JAW, THRUST_JAW)}
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
            sign = -_direction(fap)[1]  # a positive turn about x moves the margin down
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

    def _pair_share(self, v: np.ndarray, inner_pt: str, tag: str) -> np.ndarray:
        """Share of an inner or outer lip FAP at each vertex: the nearer feature point wins."""
        fp = self.face.feature_points
        d_in = np.linalg.norm(v - fp[inner_pt], axis=1)
        d_out = np.linalg.norm(v - fp[_OUTER_OF[inner_pt]], axis=1)
        total = np.maximum(d_in + d_out, 1e-9)
        return d_out / total if tag == "inner" else d_in / total

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
