"""FLAME parameter sequences in the layouts the talking-head projects write.

:func:`read_flame_params` recognises a file by its keys (case as written):

=====================  ===================================================================
layout                 keys, per frame (T rows)
=====================  ===================================================================
DiffPoseTalk           ``.npz`` (``demo.py`` ``save_coef_file``; ``utils/common.py``
                       ``get_coef_dict``): ``exp`` (T, 50), ``pose`` (T, 6) = global
                       rotation then jaw, axis-angle, ``shape`` (T, 100) or (100,)
EMOTE                  ``.pkl`` (radekd91/inferno ``inferno_apps/TalkingHead/evaluation/
                       evaluation_functions.py``, ``save_flame``): ``expression`` (T, 50),
                       ``jaw_pose`` (T, 3), ``global_pose`` (T, 3), ``shape``
EMOCA / SPECTRE codes  ``expcode`` (T, 50), ``posecode`` (T, 6) = global then jaw,
                       ``shapecode``
FLAME's own names      ``expression`` / ``exp`` / ``expression_params``, ``shape`` / ``betas``
                       / ``shape_params``, ``jaw_pose`` / ``jaw``, ``neck_pose`` / ``neck``,
                       ``eye_pose`` / ``eyes`` (T, 6: left then right),
                       ``global_pose`` / ``global_orient`` / ``rotation`` / ``root_pose``,
                       ``pose`` / ``pose_params`` (T, 6 as above, or T, 15 = the five joints),
                       ``full_pose`` (T, 15), ``transl`` / ``translation`` (T, 3)
UniTalker (DAD-Head)   a ``.npy`` of (T, 413) (X-niper/UniTalker ``loss/loss.py``,
                       ``FlameLayer.flame_params_from_3dmm``): 400 betas (300 shape, 100
                       expression), jaw (3), a 6-D rotation (left out, as UniTalker does),
                       translation (3) and scale (1)
=====================  ===================================================================

Arrays may be in a ``.npz``, a data ``.pkl`` (numpy arrays only: :mod:`app.stimuli.meshes.pickles`)
or a ``.json`` object of lists. A 1-D ``shape`` is the same in every frame. A pose column missing
from the file is 0 (FLAME's rest: the projects zero what they do not predict). ``fps`` in the file
(a number) is taken as its frame rate.

Example
-------
>>> import numpy as np
>>> p = params_from_arrays({"exp": np.zeros((3, 50)), "pose": np.ones((3, 6))}, name="a.npz")
>>> p.pose.shape, float(p.pose[0, 2, 0]), float(p.pose[0, 1, 0])
((3, 5, 3), 1.0, 0.0)
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.meshes.flame import JOINTS, FlameParams

#: Suffixes of FLAME parameter files.
PARAM_SUFFIXES: tuple[str, ...] = (".npz", ".pkl", ".json", ".npy")
#: Keys that mark a mapping as FLAME parameters (any one of them).
EXPRESSION_KEYS = ("exp", "expression", "expression_params", "expcode")
_NAMES = {
    "shape": ("shape", "betas", "shape_params", "shapecode"),
    "jaw": ("jaw_pose", "jaw"),
    "neck": ("neck_pose", "neck"),
    "eyes": ("eye_pose", "eyes", "eyeballs"),
    "global": ("global_pose", "global_orient", "rotation", "root_pose", "global"),
    "pose": ("pose", "pose_params", "posecode"),
    "full": ("full_pose",),
    "transl": ("transl", "translation"),
}
#: Columns of UniTalker's DAD-Head FLAME vectors: betas, jaw, 6-D rotation, translation, scale.
UNITALKER_WIDTH = 413


def read_param_mapping(path: str | Path, name: str | None = None) -> Mapping[str, Any]:
    """The key -> array mapping of a parameter file (``.npz``, ``.pkl``, ``.json``, or a
    UniTalker ``.npy``, given under the key ``unitalker``)."""
    p = Path(path)
    label = name or p.name
    suffix = p.suffix.lower()
    if not p.is_file():
        raise InputError("no such FLAME parameter file", path=label)
    if suffix == ".npz":
        try:
            with np.load(p, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}
        except (OSError, ValueError) as exc:
            raise InputError(f"not a readable .npz ({exc})", path=label) from None
    if suffix == ".npy":
        try:
            return {"unitalker": np.load(p, allow_pickle=False)}
        except (OSError, ValueError) as exc:
            raise InputError(f"not a readable .npy ({exc})", path=label) from None
    if suffix == ".json":
        try:
            data = json.loads(p.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError(f"not valid JSON: {exc}", path=label) from None
    else:
        from app.stimuli.meshes.pickles import load_data_pickle

        data = load_data_pickle(p, label)
    if not isinstance(data, Mapping):
        raise InputError("expected FLAME parameters by name (a dict)", path=label)
    return data


def is_flame_mapping(data: Mapping[str, Any]) -> bool:
    """Whether ``data`` holds FLAME parameters (an expression key, or UniTalker's vectors)."""
    return any(k in data for k in EXPRESSION_KEYS) or "unitalker" in data


def _get(data: Mapping[str, Any], names: tuple[str, ...]) -> Any:
    for k in names:
        if k in data:
            return data[k]
    return None


def _array(value: Any, name: str, label: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} is not numeric", path=label) from None
    if not np.isfinite(a).all():
        raise InputError(f"{name} holds NaN or infinite values", path=label)
    return a


def params_from_arrays(data: Mapping[str, Any], *, name: str) -> FlameParams:
    """FLAME parameters from a mapping in one of the layouts of the module's docstring."""
    if "unitalker" in data:
        return _unitalker(_array(data["unitalker"], "the parameters", name), name)
    expr_key = next((k for k in EXPRESSION_KEYS if k in data), None)
    if expr_key is None:
        raise InputError(
            f"no FLAME expression ({', '.join(EXPRESSION_KEYS)}) among the keys "
            f"{', '.join(map(str, data)) or 'none'}",
            path=name,
        )
    expression = _array(data[expr_key], expr_key, name)
    if expression.ndim != 2:
        raise InputError(f"{expr_key} has shape {expression.shape}, expected (T, E)", path=name)
    t = len(expression)
    pose = np.zeros((t, len(JOINTS), 3))

    def column(group: str, width: int) -> np.ndarray | None:
        value = _get(data, _NAMES[group])
        if value is None:
            return None
        a = _array(value, group, name)
        if a.shape != (t, width):
            raise InputError(
                f"{group} pose has shape {a.shape}, expected ({t}, {width}) for {t} frames",
                path=name,
            )
        return a

    full = column("full", 15)
    if full is not None:
        pose[:] = full.reshape(t, 5, 3)
    packed = _get(data, _NAMES["pose"])
    if packed is not None:
        a = _array(packed, "pose", name)
        if a.shape == (t, 15):
            pose[:] = a.reshape(t, 5, 3)
        elif a.shape == (t, 6):  # DiffPoseTalk, EMOCA: global rotation, then the jaw
            pose[:, 0], pose[:, 2] = a[:, :3], a[:, 3:]
        else:
            raise InputError(
                f"pose has shape {a.shape}, expected ({t}, 6) (global, jaw) or ({t}, 15)",
                path=name,
            )
    for group, joint in (("global", 0), ("neck", 1), ("jaw", 2)):
        given = column(group, 3)
        if given is not None:
            pose[:, joint] = given
    eyes = column("eyes", 6)
    if eyes is not None:
        pose[:, 3], pose[:, 4] = eyes[:, :3], eyes[:, 3:]
    shape = _get(data, _NAMES["shape"])
    shape_a = np.zeros(0) if shape is None else _array(shape, "shape", name)
    if shape_a.ndim == 2 and len(shape_a) != t:
        shape_a = shape_a[0]  # one shape for the sequence, repeated or not
    transl = _get(data, _NAMES["transl"])
    transl_a = None if transl is None else _array(transl, "translation", name)
    if transl_a is not None and transl_a.shape != (t, 3):
        raise InputError(f"translation has shape {transl_a.shape}, expected ({t}, 3)", path=name)
    return FlameParams(expression, pose, shape_a, transl_a)


def _unitalker(a: np.ndarray, name: str) -> FlameParams:
    if a.ndim != 2 or a.shape[1] != UNITALKER_WIDTH:
        raise InputError(
            f"expected UniTalker's FLAME vectors of shape (T, {UNITALKER_WIDTH}), got {a.shape}",
            path=name,
        )
    pose = np.zeros((len(a), len(JOINTS), 3))
    pose[:, 2] = a[:, 400:403]
    return FlameParams(a[:, 300:400], pose, a[:, :300], None)


def file_fps(data: Mapping[str, Any]) -> float | None:
    """A frame rate the file states (an ``fps`` number), else None."""
    value = data.get("fps")
    try:
        fps = float(np.asarray(value)) if value is not None else None
    except (TypeError, ValueError):
        return None
    return fps if fps and np.isfinite(fps) and fps > 0 else None
