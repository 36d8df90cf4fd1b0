"""The fixed camera every face is drawn from, framed on the face's own feature points.

A perspective camera straight in front of the face, its unit the eye-to-mouth height, so
that every face (the built-in head, an OBJ face, an avatar in any units) fills the frame
alike; :func:`project` gives the pixels world points land on (the mosaic, the markers and
the tests that look at the image follow the face with it).
"""

from __future__ import annotations

import numpy as np

from renderer.deform import Rig


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """4x4 view matrix of a camera at ``eye`` looking at ``target``, ``up`` upwards."""
    f = target - eye
    f = f / np.linalg.norm(f)
    s = np.cross(f, up)
    s = s / np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def perspective(fov_y: float, aspect: float, near: float, far: float) -> np.ndarray:
    """4x4 OpenGL projection of vertical field of view ``fov_y`` (radians) onto clip space."""
    f = 1.0 / np.tan(fov_y / 2.0)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = f / aspect, f
    m[2, 2], m[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def camera_for(rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    """Fixed camera framed on the face: (view-projection matrix, camera position).

    Frames head and neck from the feature points: the unit is the eye-to-mouth height L, the
    view spans 4.4 L vertically, centred 0.4 L below the eyes, from 10.5 L in front.
    """
    fp = rig.face.feature_points
    eyes = (fp["3.5"] + fp["3.6"]) / 2.0
    mouth = (fp["2.2"] + fp["2.3"]) / 2.0
    unit = float(eyes[1] - mouth[1])
    target = np.array([eyes[0], eyes[1] - 0.42 * unit, eyes[2] - unit])
    eye = target + np.array([0.0, 0.03 * unit, 10.5 * unit])
    fov = 2.0 * np.arctan(2.2 / 10.5)
    vp = perspective(fov, 1.0, 8.0 * unit, 14.0 * unit) @ look_at(
        eye, target, np.array([0.0, 1.0, 0.0])
    )
    return vp, eye


def project(vp: np.ndarray, points: np.ndarray, size: int) -> np.ndarray:
    """Pixel coordinates (x right, y down) of world ``points`` in a ``size`` square view."""
    h = np.column_stack([points, np.ones(len(points))]) @ vp.T
    ndc = h[:, :2] / h[:, 3:4]
    return np.column_stack([(ndc[:, 0] + 1) * size / 2, (1 - ndc[:, 1]) * size / 2])
