"""Synthetic talking heads in the layouts the 3D talking-head projects write, built by the tests.

No FLAME, VOCASET or BIWI data is shipped or fetched: :func:`head_mesh` builds an ellipsoid head
in metres (facepair's axes: +x the face's own left, +y up, +z forward) with a nose, a mouth slit
whose lower lip is a separate row of vertices, and (optionally) two eyeball spheres as separate
parts of the mesh, FLAME's way; :func:`talking` moves its jaw with a given opening per frame.
``n_vertices`` pads the mesh with unused vertices to a layout's exact count (5,023 for VOCASET's
FLAME topology, 23,370 for BIWI's).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.stimuli.meshes.meshfile import write_obj, write_ply

#: The head's semi-axes (metres): 15 cm wide, 22 cm tall, 19 cm deep.
AXES = np.array([0.075, 0.11, 0.095])
MOUTH_Y = -0.045
HINGE = np.array([0.0, -0.005, -0.03])
EYE_X, EYE_Y, EYE_R = 0.032, 0.03, 0.0125


@dataclass(frozen=True)
class Head:
    vertices: np.ndarray  # (V, 3)
    triangles: np.ndarray  # (F, 3)
    jaw_weight: np.ndarray  # (V,) how far each vertex follows the jaw
    lips: np.ndarray  # the lip vertices (the mouth slit's rows)
    eyeballs: tuple[np.ndarray, np.ndarray] | None


def _sphere(rings: int, segments: int) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere: unit points, and its (theta, phi) grid; the front (+z) at phi = 0."""
    theta = np.linspace(0.0, np.pi, rings + 1)[1:-1]  # from the top down
    phi = np.linspace(-np.pi, np.pi, segments, endpoint=False)
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    pts = np.stack([np.sin(tt) * np.sin(pp), np.cos(tt), np.sin(tt) * np.cos(pp)], axis=-1)
    return pts.reshape(-1, 3), np.stack([tt, pp], axis=-1).reshape(-1, 2)


def _grid_triangles(rows: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangles between consecutive rows of vertex indices (rows, segments), wrapping."""
    tris = []
    r, s = rows.shape
    for i in range(r - 1):
        for j in range(s):
            a, b = rows[i, j], rows[i, (j + 1) % s]
            c, d = rows[i + 1, j], rows[i + 1, (j + 1) % s]
            tris += [(a, c, b), (b, c, d)]
    return tris


def head_mesh(
    rings: int = 40, segments: int = 48, *, eyes: bool = True, n_vertices: int | None = None
) -> Head:
    unit, grid = _sphere(rings, segments)
    v = unit * AXES
    phi = grid[:, 1]
    # a nose: a bump on the front between the eyes and the mouth
    nose = np.exp(-(((v[:, 0]) / 0.012) ** 2) - ((v[:, 1] + 0.005) / 0.02) ** 2) * (v[:, 2] > 0)
    v = v + nose[:, None] * np.array([0.0, 0.0, 0.022])
    rows = np.arange(len(v)).reshape(rings - 1, segments)
    # the mouth: the ring nearest MOUTH_Y, cut on the front; the lower lip is a copy of it
    ring = int(np.argmin(np.abs(v[rows[:, 0], 1] / AXES[1] - MOUTH_Y / AXES[1])))
    front = np.abs(phi[rows[ring]]) < np.radians(22)
    cut = rows[ring][front]
    lower_lip = np.arange(len(v), len(v) + len(cut))
    v = np.vstack([v, v[cut]])
    lower_rows = rows.copy()
    lower_rows[ring, front] = lower_lip
    tris = _grid_triangles(rows[: ring + 1]) + _grid_triangles(lower_rows[ring:])
    top, bottom = len(v), len(v) + 1
    v = np.vstack([v, [[0.0, AXES[1], 0.0], [0.0, -AXES[1], 0.0]]])
    for j in range(segments):
        k = (j + 1) % segments
        tris.append((top, rows[0, j], rows[0, k]))
        tris.append((bottom, rows[-1, k], rows[-1, j]))
    below = v[:, 1] < MOUTH_Y
    jaw = np.clip((MOUTH_Y - v[:, 1]) / 0.01, 0.0, 1.0) * np.clip((v[:, 2] + 0.05) / 0.04, 0, 1)
    jaw[~below] = 0.0
    jaw[lower_lip] = 1.0
    eyeballs = None
    if eyes:
        ball, _ = _sphere(10, 14)
        ball_rows = np.arange(len(ball)).reshape(9, 14)
        ball_tris = _grid_triangles(ball_rows)
        parts = []
        for side in (1.0, -1.0):  # the face's own left (+x) first
            start = len(v)
            front_z = AXES[2] * np.sqrt(
                max(0.0, 1 - (EYE_X / AXES[0]) ** 2 - (EYE_Y / AXES[1]) ** 2)
            )
            centre = np.array([side * EYE_X, EYE_Y, front_z - 0.6 * EYE_R])
            v = np.vstack([v, centre + ball * EYE_R])
            tris += [(a + start, b + start, c + start) for a, b, c in ball_tris]
            parts.append(np.arange(start, start + len(ball)))
        eyeballs = (parts[0], parts[1])
        jaw = np.concatenate([jaw, np.zeros(len(v) - len(jaw))])
    triangles = np.array(tris, dtype=np.int32)
    if n_vertices is not None:
        if n_vertices < len(v):
            raise ValueError(f"the head has {len(v)} vertices, more than {n_vertices}")
        extra = n_vertices - len(v)
        v = np.vstack([v, np.repeat(v[:1], extra, axis=0)])
        jaw = np.concatenate([jaw, np.zeros(extra)])
    lips = np.concatenate([cut, lower_lip])
    return Head(v.astype(np.float64), triangles, jaw, lips, eyeballs)


def talking(head: Head, opening: np.ndarray, *, brows: float = 0.0) -> np.ndarray:
    """Frames ``(T, V, 3)``: the jaw turned down by ``opening`` radians per frame about the
    hinge, weighted per vertex; ``brows`` (metres) raises the forehead in the odd frames."""
    v = head.vertices
    a = np.asarray(opening, dtype=np.float64)[:, None] * head.jaw_weight[None, :]
    y, z = v[:, 1] - HINGE[1], v[:, 2] - HINGE[2]
    c, s = np.cos(a), np.sin(a)
    out = np.repeat(v[None], len(a), axis=0)
    out[:, :, 1] = HINGE[1] + c * y - s * z
    out[:, :, 2] = HINGE[2] + s * y + c * z
    if brows:
        forehead = (v[:, 1] > 0.06) & (v[:, 2] > 0)
        out[1::2, forehead, 1] += brows
    return out


def opening_from_energy(energy_db: np.ndarray, largest: float = 0.22) -> np.ndarray:
    """A jaw opening (radians) that follows the speech's energy."""
    e = np.clip((energy_db - np.percentile(energy_db, 20)) / 30.0, 0.0, 1.0)
    return largest * e


def write_layout(
    folder: Path,
    name: str,
    head: Head,
    frames: np.ndarray,
    *,
    flat: bool,
    scale: float = 1.0,
    template: str = ".obj",
) -> Path:
    """Write ``frames`` as the projects do (``flat``: FaceFormer's ``(T, V*3)``, else
    SelfTalk's ``(T, V, 3)``) in units of ``scale`` metres, with the template beside it."""
    folder.mkdir(parents=True, exist_ok=True)
    data = (frames / scale).astype(np.float32)
    path = folder / f"{name}.npy"
    np.save(path, data.reshape(len(data), -1) if flat else data)
    writer = write_obj if template == ".obj" else write_ply
    writer(folder / f"{name}{template}", head.vertices / scale, head.triangles)
    return path


#: Where the model of :func:`flame_like_model` puts its joints: the root at the neck's base,
#: the neck, the jaw at the hinge, the eyes at the eyeballs' centres (metres).
ROOT, NECK = np.array([0.0, -0.14, -0.02]), np.array([0.0, -0.09, -0.03])


def flame_like_model(head: Head, seed: int = 0, expression_scale: float = 0.004) -> dict:
    """The arrays of a FLAME model file (FLAME 2020's keys and shapes: ``v_template``, ``f``,
    ``shapedirs`` (V, 3, 400), ``posedirs`` (V, 3, 36), ``J_regressor`` (5, V), ``kintree_table``
    (2, 5), ``weights`` (V, 5)) built on the synthetic head: never FLAME. The joints are regressed
    from five marker vertices (placed among the head's unused ones); the jaw's skinning weight
    is the head's jaw weight, the eyes' their eyeballs, the neck's the rest; the first expression
    component parts the lips, the others and the shape components are small random bases, and
    the pose correctives tiny."""
    assert head.eyeballs is not None
    rng = np.random.default_rng(seed)
    v = head.vertices.copy()
    used = np.zeros(len(v), bool)
    used[head.triangles.ravel()] = True
    spare = np.flatnonzero(~used)
    if len(spare) < 5:
        v = np.vstack([v, np.zeros((5, 3))])
        spare = np.arange(len(v) - 5, len(v))
    markers = spare[:5]
    centres = [(v[b].min(axis=0) + v[b].max(axis=0)) / 2.0 for b in head.eyeballs]
    v[markers] = [ROOT, NECK, HINGE, centres[0], centres[1]]
    n = len(v)
    reg = np.zeros((5, n))
    reg[np.arange(5), markers] = 1.0
    w = np.zeros((n, 5))
    jaw = np.zeros(n)
    jaw[: len(head.jaw_weight)] = head.jaw_weight
    w[:, 2] = jaw
    w[head.eyeballs[0], 3] = 1.0
    w[head.eyeballs[1], 4] = 1.0
    w[:, 1] = 1.0 - w[:, 2:].sum(axis=1)
    shapedirs = rng.normal(0.0, 0.0005, (n, 3, 400))
    shapedirs[markers] = 0.0
    lips = np.zeros((n, 3))
    lower_lip = head.lips[len(head.lips) // 2 :]
    lips[lower_lip, 1] = -1.0
    shapedirs[:, :, 300] = lips * expression_scale
    posedirs = rng.normal(0.0, 1e-5, (n, 3, 36))
    return {
        "v_template": v,
        "f": head.triangles.astype(np.uint32),
        "shapedirs": shapedirs,
        "posedirs": posedirs,
        "J_regressor": reg,
        "kintree_table": np.array([[4294967295, 0, 1, 1, 1], [0, 1, 2, 3, 4]], dtype=np.int64),
        "weights": w,
        "bs_style": "lbs",
        "bs_type": "lrotmin",
    }


def write_flame_pkl(path: Path, arrays: dict, *, chumpy: bool = True) -> Path:
    """Write ``arrays`` as FLAME 2020's ``generic_model.pkl`` is laid out: a protocol-2 pickle of
    a dict, ``shapedirs`` and ``posedirs`` as chumpy ``Ch`` objects (made with a stand-in
    ``chumpy.ch.Ch`` that pickles as chumpy's does: its state a dict with the value under
    ``x``), ``J_regressor`` a scipy ``csc_matrix``."""
    import pickle
    import sys
    import types

    from scipy import sparse

    data = dict(arrays)
    data["J_regressor"] = sparse.csc_matrix(data["J_regressor"])
    saved = {k: sys.modules.get(k) for k in ("chumpy", "chumpy.ch")}
    if chumpy:

        class Ch:
            def __init__(self, x: np.ndarray) -> None:
                self.x = x

        Ch.__module__, Ch.__qualname__ = "chumpy.ch", "Ch"
        module = types.ModuleType("chumpy.ch")
        module.Ch = Ch  # type: ignore[attr-defined]
        sys.modules["chumpy"], sys.modules["chumpy.ch"] = types.ModuleType("chumpy"), module
        data["shapedirs"], data["posedirs"] = Ch(data["shapedirs"]), Ch(data["posedirs"])
    try:
        path.write_bytes(pickle.dumps(data, protocol=2))
    finally:
        for k, m in saved.items():
            if m is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = m
    return path
