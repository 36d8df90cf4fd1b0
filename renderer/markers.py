"""The "marker" look: a face as the thesis' infrared camera saw it (sec. 3.1.1, 3.1.3).

The thesis' IR camera, with a visible-light filter and its LEDs on the lens axis, shows a
dark face and bright retro-reflective markers (its fig. 4-6). This look renders exactly
that, for a closed-loop test of the marker capture (:mod:`app.stimuli.capture.markers`):
known FAP tracks in, the clip the capture would have recorded out.

* Markers: the thesis' 13 face markers on the deformed skin and the 4 post markers of the
  head-mounted frame rigidly attached to the head (:mod:`app.stimuli.capture.markerset`).
  The face is posed by the renderer's own deformation (:meth:`renderer.deform.Rig.posed`)
  and seen through its camera (:func:`renderer.camera.camera_for`), so the markers move as the
  rendered face does.
* Each marker is a disc of ``marker_mm`` diameter (at least ``min_diameter_px``), drawn with
  anti-aliased edges at its sub-pixel position; a skin marker facing away from the camera
  is hidden (the outer eyebrows vanishing under yaw, fig. 9). Occlusion by other parts of
  the face is not modelled.
* The face is a dark silhouette (grey ``face_level``), splatted from the posed vertices and
  closed; no GL is needed, since the camera sees only the markers and the silhouette.
* Optional lens blur (Gaussian, ``blur_px``) and sensor noise (Gaussian, ``noise`` grey
  levels, seeded).

Example
-------
>>> import numpy as np
>>> from app.stimuli.track import MotionTrack
>>> track = MotionTrack.zeros(30.0, 2, (48,))
>>> frames = list(marker_frames(track, 128))
>>> frames[0].shape, frames[0].dtype.name, int(frames[0].max()) > 200
((128, 128), 'uint8', True)
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import ndimage

from app.stimuli.capture.markerset import HEAD_FRAME, MARKERS, POSTS, SITES, HeadFrame
from app.stimuli.fap import AU_RADIANS, HEAD_PITCH, HEAD_ROLL, HEAD_YAW
from app.stimuli.track import MotionTrack
from renderer.camera import camera_for, project
from renderer.deform import Rig
from renderer.face import Face


@dataclass(frozen=True)
class MarkerLook:
    """How the marker clip looks (see the module text)."""

    marker_mm: float = 3.0
    min_diameter_px: float = 3.0
    face_level: float = 40.0
    marker_level: float = 255.0
    blur_px: float = 0.6
    noise: float = 0.0
    seed: int = 0
    frame: HeadFrame = field(default_factory=lambda: HEAD_FRAME)


def marker_vertices(face: Face) -> dict[str, int]:
    """Vertex index of each face marker: its feature point's vertex, else the skin vertex in
    front of its site (the front-most of the forward-facing vertices nearest in x, y)."""
    fp = face.feature_points
    eyes = (fp["3.5"] + fp["3.6"]) / 2.0
    v = face.vertices.astype(np.float64)
    facing = face.normals()[:, 2] > 0.3
    for side in ("l", "r"):
        facing[face.groups[f"eyeball_{side}"]] = False
    out = {}
    for name, site in SITES.items():
        if site.feature_point in face.fp_vertices:
            out[name] = face.fp_vertices[site.feature_point]
            continue
        target = eyes[:2] + [site.x * face.fapu["ES0"], site.y * face.fapu["ENS0"]]
        d = np.where(facing, np.linalg.norm(v[:, :2] - target, axis=1), np.inf)
        near = np.flatnonzero(d <= d.min() + 1.0)
        out[name] = int(near[np.argmax(v[near, 2])])
    return out


def frame_points(face: Face, frame: HeadFrame = HEAD_FRAME) -> np.ndarray:
    """Neutral positions of the post markers TL, TR, BL, BR (camera's left = face's right)."""
    fp = face.feature_points
    eyes = (fp["3.5"] + fp["3.6"]) / 2.0
    x = frame.half_width * face.fapu["ES0"]
    z = eyes[2] + frame.depth * face.fapu["ENS0"]
    top, bottom = (eyes[1] + h * face.fapu["ENS0"] for h in (frame.top, frame.bottom))
    return np.array([[-x, top, z], [x, top, z], [-x, bottom, z], [x, bottom, z]])


class MarkerCamera:
    """Poses a face by FAPs and returns its markers' pixel positions and visibility."""

    def __init__(self, face: Face, size: int, look: MarkerLook = MarkerLook()) -> None:
        self.rig, self.size, self.look = Rig(face), size, look
        self.vp, self.eye = camera_for(self.rig)
        self.skin = marker_vertices(face)
        self.posts = frame_points(face, look.frame)
        self._skin_idx = np.array([self.skin[n] for n in SITES])

    def pose(self, faps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(pixels (17, 2), visible (17,), diameters px (17,), silhouette vertices px)``
        for one frame of 68 FAP values, markers in :data:`MARKERS` order."""
        frame = self.rig.deform(faps)
        positions, normals = self.rig.posed(frame)
        head = frame.head
        posts = self.posts @ head[:3, :3].T + head[:3, 3]
        skin = positions[self._skin_idx].astype(np.float64)
        world = np.vstack([posts, skin])
        facing = np.einsum("ij,ij->i", normals[self._skin_idx], self.eye - skin) > 0.0
        visible = np.r_[np.ones(len(POSTS), bool), facing]
        px = project(self.vp, world, self.size)
        across = project(self.vp, world + [self.look.marker_mm / 2.0, 0.0, 0.0], self.size)
        diameter = np.maximum(2.0 * np.linalg.norm(across - px, axis=1), self.look.min_diameter_px)
        return px, visible, diameter, project(self.vp, positions, self.size)


#: Barycentric sample points per triangle for the silhouette (a 4-step grid on each).
_BARY = np.array([(i, j, 4 - i - j) for i in range(5) for j in range(5 - i)]) / 4.0


def silhouette(vertices_px: np.ndarray, triangles: np.ndarray, size: int) -> np.ndarray:
    """Pixels covered by the projected mesh: a grid of points on every triangle, closed."""
    corners = vertices_px[triangles]  # (m, 3, 2)
    pts = np.einsum("sk,mkd->smd", _BARY, corners).reshape(-1, 2)
    ij = np.floor(pts).astype(int)
    inside = (ij >= 0).all(axis=1) & (ij < size).all(axis=1)
    mask = np.zeros((size, size), bool)
    mask[ij[inside, 1], ij[inside, 0]] = True
    return ndimage.binary_fill_holes(ndimage.binary_closing(mask, iterations=2))


def draw_marker_frame(
    px: np.ndarray,
    visible: np.ndarray,
    diameter: np.ndarray,
    outline: np.ndarray,
    triangles: np.ndarray,
    size: int,
    look: MarkerLook = MarkerLook(),
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """One (size, size) uint8 IR frame: dark silhouette, anti-aliased marker discs, blur,
    noise."""
    img = np.where(silhouette(outline, triangles, size), look.face_level, 0.0)
    radius = diameter[visible] / 2.0
    centres = px[visible]
    half = int(np.ceil(radius.max() + 1.5)) if len(radius) else 0
    offsets = np.arange(-half, half + 1)
    for (cx, cy), r in zip(centres, radius, strict=True):
        xs = np.clip(int(round(cx)) + offsets, 0, size - 1)
        ys = np.clip(int(round(cy)) + offsets, 0, size - 1)
        # pixel centres at integer + 0.5 in the projection's continuous coordinates
        d = np.hypot(xs[None, :] + 0.5 - cx, ys[:, None] + 0.5 - cy)
        cover = np.clip(r + 0.5 - d, 0.0, 1.0)
        patch = img[np.ix_(ys, xs)]
        img[np.ix_(ys, xs)] = patch + cover * (look.marker_level - patch)
    if look.blur_px > 0:
        img = ndimage.gaussian_filter(img, look.blur_px)
    if look.noise > 0:
        rng = rng if rng is not None else np.random.default_rng(look.seed)
        img = img + rng.normal(0.0, look.noise, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def marker_frames(
    track: MotionTrack,
    size: int,
    face: Face | None = None,
    look: MarkerLook = MarkerLook(),
    hidden: Mapping[str, np.ndarray] | None = None,
) -> Iterator[np.ndarray]:
    """The marker clip of ``track`` frame by frame, (size, size) uint8 grey.

    ``hidden`` maps a marker name to the frame numbers in which it is not seen (a marker
    occluded or fallen off), for tests of the capture's gap recovery.
    """
    from renderer.headmodel import builtin_face

    camera = MarkerCamera(face if face is not None else builtin_face(), size, look)
    rng = np.random.default_rng(look.seed)
    dense = track.dense()
    hide = {MARKERS.index(k): set(np.asarray(v).tolist()) for k, v in (hidden or {}).items()}
    for t in range(track.n_frames):
        px, visible, diameter, outline = camera.pose(dense[t])
        for k, frames in hide.items():
            if t in frames:
                visible[k] = False
        yield draw_marker_frame(
            px, visible, diameter, outline, camera.rig.face.triangles, size, look, rng
        )


def write_marker_clip(
    track: MotionTrack,
    path: str | Path,
    size: int,
    face: Face | None = None,
    look: MarkerLook = MarkerLook(),
    hidden: Mapping[str, np.ndarray] | None = None,
    crf: int = 12,
) -> Path:
    """Encode the marker clip of ``track`` as an H.264 MP4 at the track's frame rate."""
    from renderer.encode import ClipWriter

    with ClipWriter(path, size, size, track.fps, track.n_frames, crf=crf) as writer:
        for grey in marker_frames(track, size, face, look, hidden):
            writer.write(np.repeat(grey[:, :, None], 3, axis=2))
    return Path(path)


def calibration_motion(fps: float = 30.0, seconds: float = 4.0) -> MotionTrack:
    """A neutral face nodding to +/-17 degrees, then turning to +/-8 degrees (the thesis'
    calibration angles, sec. 3.2.2): the known motion for calibrating the capture."""
    t = np.arange(int(round(seconds * fps))) / fps
    half = seconds / 2.0
    nod = np.where(t < half, np.radians(17.0) * np.sin(2 * np.pi * t / half), 0.0)
    turn = np.where(t >= half, np.radians(8.0) * np.sin(2 * np.pi * (t - half) / half), 0.0)
    return MotionTrack.from_channels(
        fps,
        {HEAD_PITCH: nod / AU_RADIANS, HEAD_YAW: turn / AU_RADIANS},
        source="marker calibration motion",
    )


def known_motion(fps: float = 30.0, seconds: float = 4.0) -> MotionTrack:
    """Head pitch, yaw and roll within the thesis' ranges (12, 6 and 8 degrees) at unrelated
    rates, and two eyebrow raises (inner 40, middle 30 ENS units, raised-cosine ramps of
    0.25 s), all from a neutral first half second: the closed-loop test's known motion."""
    t = np.arange(int(round(seconds * fps))) / fps
    ramp = np.clip((t - 0.5) / 0.5, 0.0, 1.0)
    angles = {
        HEAD_PITCH: (12.0, 0.45, 0.0),
        HEAD_YAW: (6.0, 0.31, 0.7),
        HEAD_ROLL: (8.0, 0.53, 1.9),
    }
    cols = {
        f: np.radians(a) * np.sin(2 * np.pi * hz * (t - 0.5) + ph) * ramp / AU_RADIANS
        for f, (a, hz, ph) in angles.items()
    }
    raise_ = np.zeros_like(t)
    for start, hold in ((1.0, 0.5), (2.4, 0.8)):
        up = np.clip((t - start) / 0.25, 0, 1) - np.clip((t - start - 0.25 - hold) / 0.25, 0, 1)
        raise_ += 0.5 - 0.5 * np.cos(np.pi * up)
    for f, amplitude in ((31, 40.0), (32, 40.0), (33, 30.0), (34, 30.0)):
        cols[f] = amplitude * raise_
    return MotionTrack.from_channels(fps, cols, source="marker test motion")
