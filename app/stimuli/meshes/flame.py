"""FLAME's forward model in numpy: shape, expression and pose to vertices.

FLAME (Li, Bolkart, Black, Li & Romero 2017, "Learning a model of facial shape and expression
from 4D scans", ACM Trans. Graph. 36(6), SIGGRAPH Asia; sec. 3, eqs. 1-4) is licence-gated:
facepair never ships, downloads or fetches it. A user who has it points facepair at her own
model file (:data:`MODEL_VARIABLE`, or ``flame_model`` in a study file), and
:func:`flame_vertices` computes, for each frame,

* ``T_P = T + B_S(beta; S) + B_E(psi; E) + B_P(theta; P)``: the template plus the shape and the
  expression blendshapes (linear in their coefficients: ``shapedirs``, the first
  :attr:`FlameModel.n_shape` columns shape, the rest expression) plus the pose correctives
  (``posedirs`` times the 36 elements of ``R(theta_k) - I`` of the four non-root joints);
* the joints ``J = J_regressor (T + B_S + B_E)`` (eq. 3: from the shaped, expressive mesh);
* linear blend skinning (eq. 1): each vertex moved by the ``weights``-weighted sum of the
  joints' world transforms relative to their rest positions, along ``kintree_table``'s chain
  (root/global, neck, jaw, left eye, right eye).

It is the computation of the public implementations (smplx ``lbs.py``, which FLAME_PyTorch and
DiffPoseTalk ``models/lbs.py`` take over; TimoBolkart/TF_FLAME), vectorised over frames.

Files read (:func:`read_flame_model`): FLAME 2020's ``generic_model.pkl`` (chumpy arrays, read
without chumpy: :mod:`app.stimuli.meshes.pickles`), FLAME 2023's ``flame2023.pkl`` and
``flame2023_no_jaw.pkl``, and a ``.npz`` with the same keys (``v_template`` (V, 3), ``f``
(F, 3), ``shapedirs`` (V, 3, 400): 300 shape and 100 expression components, ``posedirs``
(V, 3, 36), ``J_regressor`` (5, V) dense or sparse, ``kintree_table`` (2, 5), ``weights``
(V, 5)); any vertex count, so a test builds a model of the same structure with random bases.
FLAME 2017's ``male``/``female``/``generic_model.pkl`` have the same layout and are read too.

Example
-------
>>> import numpy as np
>>> m = FlameModel.random(n_vertices=30, seed=1)
>>> v = flame_vertices(m, FlameParams.zeros(2))
>>> bool(np.allclose(v[0], m.v_template)), v.shape
(True, (2, 30, 3))
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.errors import InputError
from app.stimuli.meshes.vertexfile import rodrigues

#: The environment variable naming the user's own FLAME model file.
MODEL_VARIABLE = "FACEPAIR_FLAME_MODEL"
#: FLAME's joints, in the order of its pose vector (3 axis-angle values each).
JOINTS: tuple[str, ...] = ("global", "neck", "jaw", "eye_l", "eye_r")
#: Shape and expression components of FLAME 2020 and 2023 (``shapedirs`` has both).
N_SHAPE, N_EXPRESSION = 300, 100
_KEYS = ("v_template", "f", "shapedirs", "posedirs", "J_regressor", "kintree_table", "weights")


@dataclass(frozen=True, eq=False)
class FlameModel:
    """A FLAME model's arrays (see the module's docstring); float64, ``posedirs`` as
    ``(36, V*3)`` and ``parents`` with -1 for the root."""

    v_template: np.ndarray
    faces: np.ndarray
    shapedirs: np.ndarray  # (V, 3, n_shape + n_expression)
    posedirs: np.ndarray  # (36, V * 3)
    j_regressor: np.ndarray  # (5, V)
    parents: np.ndarray  # (5,)
    weights: np.ndarray  # (V, 5)
    n_shape: int = N_SHAPE
    name: str = "FLAME"

    @property
    def n_vertices(self) -> int:
        return int(self.v_template.shape[0])

    @property
    def n_expression(self) -> int:
        return int(self.shapedirs.shape[2]) - self.n_shape

    @classmethod
    def random(cls, n_vertices: int = 5023, seed: int = 0, scale: float = 0.001) -> FlameModel:
        """A model of FLAME's structure with random bases (for tests): a random template, a
        kinematic chain root -> neck -> (jaw, eye_l, eye_r) with joints regressed from the
        template, and random skinning weights summing to 1. Never FLAME itself."""
        rng = np.random.default_rng(seed)
        v = rng.normal(0.0, 0.05, (n_vertices, 3))
        reg = rng.random((len(JOINTS), n_vertices))
        reg /= reg.sum(axis=1, keepdims=True)
        w = rng.random((n_vertices, len(JOINTS))) ** 4
        w /= w.sum(axis=1, keepdims=True)
        faces = np.array([[i, i + 1, i + 2] for i in range(n_vertices - 2)], dtype=np.int32)
        return cls(
            v_template=v,
            faces=faces,
            shapedirs=rng.normal(0.0, scale, (n_vertices, 3, N_SHAPE + N_EXPRESSION)),
            posedirs=rng.normal(0.0, scale, (36, n_vertices * 3)),
            j_regressor=reg,
            parents=np.array([-1, 0, 1, 1, 1]),
            weights=w,
            name="random FLAME-structured model",
        )


def model_path(given: str | Path | None = None) -> Path:
    """The FLAME model file to use: ``given``, else :data:`MODEL_VARIABLE`'s; without either,
    one line saying what is needed."""
    chosen = given or os.environ.get(MODEL_VARIABLE)
    if not chosen:
        raise InputError(
            "a FLAME parameter sequence needs your own FLAME model file, which facepair never "
            f"ships or downloads: set {MODEL_VARIABLE} (or flame_model in the study file) to "
            "FLAME 2020's generic_model.pkl or FLAME 2023's flame2023.pkl from "
            "https://flame.is.tue.mpg.de",
            field="flame_model",
        )
    path = Path(chosen).expanduser()
    if not path.is_file():
        raise InputError("no such FLAME model file", path=path)
    return path


def read_flame_model(path: str | Path) -> FlameModel:
    """A FLAME model from a ``.pkl`` (FLAME 2017, 2020, 2023) or ``.npz`` file."""
    p = Path(path)
    if p.suffix.lower() == ".npz":
        try:
            with np.load(p, allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}
        except (OSError, ValueError) as exc:
            raise InputError(f"not a readable FLAME .npz ({exc})", path=p) from None
    else:
        from app.stimuli.meshes.pickles import load_data_pickle

        data = load_data_pickle(p)
    if not isinstance(data, dict):
        raise InputError("expected a FLAME model (a dict of arrays)", path=p)
    missing = [k for k in _KEYS if k not in data]
    if missing:
        raise InputError(f"not a FLAME model: no {', '.join(missing)}", path=p)
    try:
        v = np.asarray(data["v_template"], dtype=np.float64)
        n = len(v)
        shapedirs = np.asarray(data["shapedirs"], dtype=np.float64)
        posedirs = np.asarray(data["posedirs"], dtype=np.float64)
        reg = np.asarray(data["J_regressor"], dtype=np.float64)
        kintree = np.asarray(data["kintree_table"], dtype=np.int64)
        weights = np.asarray(data["weights"], dtype=np.float64)
        faces = np.asarray(data["f"], dtype=np.int64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"a FLAME array is not numeric ({exc})", path=p) from None
    k = len(JOINTS)
    checks = {
        "v_template": (v.shape, (n, 3)),
        "shapedirs": (shapedirs.shape[:2], (n, 3)),
        "posedirs": (posedirs.shape, (n, 3, 9 * (k - 1))),
        "J_regressor": (reg.shape, (k, n)),
        "kintree_table": (kintree.shape, (2, k)),
        "weights": (weights.shape, (n, k)),
    }
    for key, (got, want) in checks.items():
        if tuple(got) != want:
            raise InputError(f"{key} has shape {tuple(got)}, FLAME's is {want}", path=p)
    if shapedirs.ndim != 3 or shapedirs.shape[2] <= N_SHAPE:
        raise InputError(
            f"shapedirs has {shapedirs.shape[2:]} components: FLAME 2020 and 2023 hold "
            f"{N_SHAPE} shape and {N_EXPRESSION} expression components",
            path=p,
        )
    if faces.ndim != 2 or faces.shape[1] != 3 or faces.min() < 0 or faces.max() >= n:
        raise InputError("f is not a triangle list of the template's vertices", path=p)
    parents = kintree[0].copy()
    parents[0] = -1
    return FlameModel(
        v_template=v,
        faces=faces.astype(np.int32),
        shapedirs=shapedirs,
        posedirs=posedirs.reshape(-1, posedirs.shape[2]).T.copy(),
        j_regressor=reg,
        parents=parents,
        weights=weights,
        name=p.name,
    )


@dataclass
class FlameParams:
    """FLAME parameters per frame: ``expression`` (T, E), ``pose`` (T, 5, 3) axis-angle in
    :data:`JOINTS` order, ``shape`` (S,) or (T, S), ``translation`` (T, 3) or None. Fewer
    shape or expression components than the model has are the leading ones (the rest 0)."""

    expression: np.ndarray
    pose: np.ndarray
    shape: np.ndarray = field(default_factory=lambda: np.zeros(0))
    translation: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        return int(self.pose.shape[0])

    @classmethod
    def zeros(cls, n_frames: int) -> FlameParams:
        return cls(np.zeros((n_frames, 0)), np.zeros((n_frames, len(JOINTS), 3)))


def _padded(coeffs: np.ndarray, n: int, what: str) -> np.ndarray:
    c = np.asarray(coeffs, dtype=np.float64)
    if c.shape[-1] > n:
        raise InputError(f"{c.shape[-1]} {what} coefficients, the model has {n}", field=what)
    pad = [(0, 0)] * (c.ndim - 1) + [(0, n - c.shape[-1])]
    return np.pad(c, pad)


def flame_vertices(model: FlameModel, params: FlameParams) -> np.ndarray:
    """Vertices ``(T, V, 3)`` of ``params`` on ``model`` (see the module's docstring)."""
    t = params.n_frames
    n_v = model.n_vertices
    beta = _padded(params.shape, model.n_shape, "shape")
    psi = _padded(params.expression, model.n_expression, "expression")
    shape_dirs = model.shapedirs[:, :, : model.n_shape].reshape(n_v * 3, -1)
    expr_dirs = model.shapedirs[:, :, model.n_shape :].reshape(n_v * 3, -1)
    shaped = (shape_dirs @ beta.T).T.reshape(-1, n_v, 3)  # (1 or T, V, 3)
    shaped = model.v_template + shaped + (psi @ expr_dirs.T).reshape(t, n_v, 3)
    joints = np.einsum("jv,tvc->tjc", model.j_regressor, shaped)
    rot = rodrigues(np.asarray(params.pose, dtype=np.float64))  # (T, 5, 3, 3)
    feature = (rot[:, 1:] - np.eye(3)).reshape(t, -1)
    posed = shaped + (feature @ model.posedirs).reshape(t, n_v, 3)
    # world transforms of the joints along the chain, then relative to their rest positions
    world_r = np.empty_like(rot)
    world_t = np.empty((t, len(model.parents), 3))
    for j, parent in enumerate(model.parents):
        if parent < 0:
            world_r[:, j], world_t[:, j] = rot[:, j], joints[:, j]
            continue
        local = joints[:, j] - joints[:, parent]
        world_r[:, j] = world_r[:, parent] @ rot[:, j]
        world_t[:, j] = world_t[:, parent] + np.einsum("tab,tb->ta", world_r[:, parent], local)
    rel_t = world_t - np.einsum("tjab,tjb->tja", world_r, joints)
    out = np.zeros_like(posed)
    for j in range(len(model.parents)):
        w = model.weights[:, j][None, :, None]
        out += w * (np.einsum("tab,tvb->tva", world_r[:, j], posed) + rel_t[:, j, None, :])
    if params.translation is not None:
        out += np.asarray(params.translation, dtype=np.float64)[:, None, :]
    return out


def rest_joints(model: FlameModel, shape: np.ndarray | None = None) -> np.ndarray:
    """The joints ``(5, 3)`` of the shaped template at rest (the head's pivot is the neck)."""
    beta = _padded(np.zeros(0) if shape is None else shape, model.n_shape, "shape")
    if beta.ndim > 1:
        beta = beta[0]
    dirs = model.shapedirs[:, :, : model.n_shape]
    return model.j_regressor @ (model.v_template + dirs @ beta)
