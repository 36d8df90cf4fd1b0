"""Vertex sequences as the speech-driven 3D talking-head projects write them.

The projects predict one mesh per video frame on a fixed topology and save the sequence with
``numpy.save``:

* FaceFormer (EvelynFan/FaceFormer ``demo.py``): ``prediction.squeeze()`` of shape
  ``(T, V*3)``, x, y, z of each vertex in turn, to ``<wav name>.npy``; VOCASET at 30 fps
  (``--vertice_dim 15069``, 5,023 FLAME vertices, metres), BIWI at 25 fps (``--vertice_dim
  70110``, 23,370 vertices);
* CodeTalker (Doubiiu/CodeTalker ``main/demo.py``): the same ``(T, V*3)`` array, to
  ``<wav name>/condition_<c>_subject_<s>.npy``; its data preparation writes the ground truth the
  same way (``vocaset/process_voca_data.py``: ``reshape(-1, 5023*3)``;
  ``BIWI/data_preprocess/load_mat_to_multiple_vert_np.py``: 23,370 x 3 per frame);
* SelfTalk (psyai-net/SelfTalk_release): ``(T, V*3)`` from ``demo_voca.py``, ``(T, V, 3)`` from
  ``test.py``;
* UniTalker (X-niper/UniTalker ``main/demo.py``): a ``.npz`` holding a dict of ``(T, V, 3)``
  arrays per audio and annotation type, pickled (see docs/reference/meshes.md for taking one
  out: facepair loads no pickled arrays from ``.npz``).

:func:`read_vertex_array` reads ``.npy`` (one array) and ``.npz`` (the array under ``vertices``,
``verts``, ``vertice``, ``prediction`` or ``pred``, else the only array of 2 or 3 dimensions),
of shape ``(T, V, 3)`` or ``(T, 3V)``, and checks it against the template's vertex count.

Units (:data:`UNITS`): the FLAME topology is in metres; BIWI as these projects store it is in
units of 0.2 m (UniTalker's ``dataset/dataset_config.py`` scales BIWI by 0.2 and VOCASET by 1 to
bring both to one space; ``BIWI.ply`` is 0.77 units wide, a 15 cm face); MeshTalk's in
millimetres (scale 0.001 there). :func:`detect_units` takes the unit that makes the template's
width a head's (:data:`HEAD_WIDTH_M`).

Example
-------
>>> import numpy as np
>>> seq = np.zeros((4, 6))
>>> read_vertex_array(seq, n_vertices=2, name="face.npy").shape
(4, 2, 3)
>>> detect_units(np.array([[-0.08, 0, 0], [0.08, 0.1, 0.05]]), name="t.obj")
'm'
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from app.errors import InputError

#: Metres per unit of each unit a sequence may be in. ``biwi``: BIWI as FaceFormer, CodeTalker,
#: SelfTalk and UniTalker store it (0.2 m a unit; UniTalker's dataset_config).
UNITS: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001, "biwi": 0.2}
#: The widths (metres, the template's x extent) a human head's mesh can have: a face mask
#: (about 0.12 m) to a whole head with ears and a bust's shoulders (about 0.45 m).
HEAD_WIDTH_M: tuple[float, float] = (0.08, 0.5)
#: BIWI's vertex count (the face scans of Fanelli et al. 2010 as the projects store them).
BIWI_VERTICES = 23370
#: Keys an ``.npz`` vertex file may hold its sequence under, in the order tried.
ARRAY_KEYS: tuple[str, ...] = ("vertices", "verts", "vertice", "prediction", "pred")


def load_array(path: str | Path, name: str | None = None) -> np.ndarray:
    """The vertex array of a ``.npy`` or ``.npz`` file (see the module's docstring)."""
    label = name or Path(path).name
    suffix = Path(path).suffix.lower()
    try:
        with open(path, "rb") as fh:
            magic = fh.read(6)
    except FileNotFoundError:
        raise InputError("no such vertex file", path=label) from None
    except OSError as exc:
        raise InputError(f"cannot read the vertex file: {exc.strerror}", path=label) from None
    if magic != b"\x93NUMPY" and not magic.startswith(b"PK"):
        raise InputError(f"not a numpy {suffix} file (numpy.save or numpy.savez)", path=label)
    try:
        loaded = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise InputError("no such vertex file", path=label) from None
    except ValueError as exc:
        if "pickle" in str(exc):
            raise InputError(
                "holds pickled objects (UniTalker's .npz holds a dict per audio): save the "
                "(T, V, 3) array with numpy.save and give that",
                path=label,
            ) from None
        raise InputError(f"not a numpy {suffix} file: {exc}", path=label) from None
    except (OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError(f"not a readable numpy {suffix} file ({exc})", path=label) from None
    if isinstance(loaded, np.ndarray):
        return loaded
    with loaded:
        try:
            keys = list(loaded.keys())
            for key in ARRAY_KEYS:
                if key in keys:
                    return np.asarray(loaded[key])
            arrays = [k for k in keys if loaded[k].ndim in (2, 3)]
        except ValueError:
            raise InputError(
                "holds pickled objects (UniTalker's .npz holds a dict per audio): save the "
                "(T, V, 3) array with numpy.save and give that",
                path=label,
            ) from None
        if len(arrays) != 1:
            raise InputError(
                f"expected one vertex array (or one named {', '.join(ARRAY_KEYS)}), found "
                f"{', '.join(keys) or 'none'}",
                path=label,
            )
        return np.asarray(loaded[arrays[0]])


def read_vertex_array(array: np.ndarray, *, n_vertices: int, name: str) -> np.ndarray:
    """``array`` as float32 ``(T, V, 3)``, checked: ``(T, V, 3)`` or ``(T, 3V)`` with V the
    template's vertex count, at least one frame, every value finite."""
    a = np.asarray(array)
    if a.dtype.kind not in "fiu":
        raise InputError(f"expected numbers, got an array of {a.dtype}", path=name)
    if a.ndim == 3 and a.shape[2] == 3:
        frames = a
    elif a.ndim == 2 and a.shape[1] % 3 == 0 and a.shape[1] != 3:
        frames = a.reshape(a.shape[0], a.shape[1] // 3, 3)
    else:
        raise InputError(f"expected frames of shape (T, V, 3) or (T, 3V), got {a.shape}", path=name)
    if frames.shape[1] != n_vertices:
        raise InputError(
            f"{frames.shape[1]} vertices per frame, but the template has {n_vertices}", path=name
        )
    if not len(frames):
        raise InputError("no frames", path=name)
    bad = ~np.isfinite(frames)
    if bad.any():
        t, v = (int(i) for i in np.argwhere(bad)[0][:2])
        raise InputError(
            f"{int(bad.any(axis=(1, 2)).sum())} frame(s) hold NaN or infinite values "
            f"(first: frame {t}, vertex {v})",
            path=name,
        )
    return frames.astype(np.float32, copy=False)


def head_width(vertices: np.ndarray) -> float:
    """The x extent of a mesh, in its own units."""
    v = np.asarray(vertices, dtype=np.float64)
    return float(v[:, 0].max() - v[:, 0].min()) if len(v) else 0.0


def detect_units(template: np.ndarray, *, name: str, declared: str = "auto") -> str:
    """The unit of ``template`` (:data:`UNITS`): the declared one, checked, or (``"auto"``)
    the one that gives it a head's width; BIWI's unit for a BIWI-sized template of BIWI's
    vertex count. An implausible size is one line saying what to declare."""
    width = head_width(template)
    lo, hi = HEAD_WIDTH_M
    if declared != "auto":
        if declared not in UNITS:
            raise InputError(
                f"unknown units {declared!r}: expected auto, {', '.join(UNITS)}", field="units"
            )
        metres = width * UNITS[declared]
        if not lo <= metres <= hi:
            raise InputError(
                f"units implausible: in {declared} the template is {metres:.3g} m wide, not a "
                f"head's {lo:g}-{hi:g} m; declare the units it is in",
                path=name,
            )
        return declared
    candidates = ["m", "mm", "cm"]
    if len(template) == BIWI_VERTICES:
        candidates.insert(0, "biwi")
    for unit in candidates:
        if lo <= width * UNITS[unit] <= hi:
            return unit
    raise InputError(
        f"units implausible: the template is {width:.4g} units wide, a head in none of "
        f"{', '.join(UNITS)}; declare its units (and check it is a head)",
        path=name,
    )


def read_pose_array(array: np.ndarray, n_frames: int, *, name: str) -> np.ndarray:
    """A head pose per frame as rotation matrices ``(T, 3, 3)``: from axis-angle vectors in
    radians ``(T, 3)`` (FLAME's convention), the same followed by a translation ``(T, 6)``
    (left out: facepair's heads turn but do not travel), or matrices ``(T, 3, 3)``."""
    a = np.asarray(array, dtype=np.float64)
    if a.ndim == 2 and a.shape[1] in (3, 6):
        rot = rodrigues(a[:, :3])
    elif a.ndim == 3 and a.shape[1:] == (3, 3):
        rot = a
    else:
        raise InputError(
            f"expected a head pose per frame, (T, 3) axis-angle, (T, 6) or (T, 3, 3), got "
            f"{a.shape}",
            path=name,
        )
    if len(rot) != n_frames:
        raise InputError(f"{len(rot)} poses for {n_frames} frames", path=name)
    if not np.isfinite(rot).all():
        raise InputError("a pose holds NaN or infinite values", path=name)
    return rot


def rodrigues(vectors: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of axis-angle vectors ``(..., 3)`` (radians):
    ``I + sin(t) K + (1 - cos(t)) K^2`` with K the cross-product matrix of the unit axis
    (Rodrigues' formula; smplx's ``batch_rodrigues``)."""
    r = np.asarray(vectors, dtype=np.float64)
    theta = np.linalg.norm(r, axis=-1, keepdims=True)
    k = np.divide(r, theta, out=np.zeros_like(r), where=theta > 1e-12)
    x, y, z = k[..., 0], k[..., 1], k[..., 2]
    zero = np.zeros_like(x)
    kmat = np.stack([zero, -z, y, z, zero, -x, -y, x, zero], axis=-1).reshape(*r.shape[:-1], 3, 3)
    s, c = np.sin(theta)[..., None], np.cos(theta)[..., None]
    return np.eye(3) + s * kmat + (1.0 - c) * (kmat @ kmat)
