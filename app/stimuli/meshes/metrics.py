"""The 3D talking-head field's objective metrics: lip vertex error and upper-face dynamics.

Both compare a predicted vertex sequence with the ground truth of the same topology, frame by
frame (the prediction cut to the ground truth's length, as the projects' evaluation does).

**Lip vertex error** (LVE; FaceFormer, Fan et al. CVPR 2022, sec. 4.2, after MeshTalk, Richard
et al. ICCV 2021): per frame the largest error over the lip vertices, averaged over the frames.
The papers call it "the maximal L2 error"; their code squares it (Doubiiu/CodeTalker
``main/cal_metric.py``: ``np.max(np.sum(np.square(gt - pred), axis=2))`` over the mouth map,
then the mean; UniTalker ``loss/loss.py`` ``mouth_metric`` returns both, the square and its
root), and the published tables (e.g. VOCASET 4.1e-5, BIWI 4.9e-4) are in those squared units.
facepair reports both: :attr:`LipVertexError.mm`, the distance in millimetres, and
:attr:`LipVertexError.squared`, the code's number in the file's own units squared (metres for
VOCASET and FLAME, BIWI's 0.2 m units for BIWI), comparable with the tables.

**Upper-face dynamics deviation** (FDD; CodeTalker, Xing et al. CVPR 2023, sec. 4.1): for each
upper-face vertex, the standard deviation over time of its motion (its displacement from the
template's position) in the ground truth minus that in the prediction, averaged over the upper-
face vertices. The paper's motion is the displacement's L2 norm; the code again takes the
square (``np.sum(np.square(motion), axis=2)``, then ``np.std`` over frames, the mean over the
upper map, ground truth minus prediction), both against the ground truth's subject template.
facepair reports :attr:`UpperFaceDynamics.mm` (the norm, millimetres) and
:attr:`UpperFaceDynamics.squared` (the code's, file units squared). Positive: the prediction's
upper face moves less than the ground truth's.

Example
-------
>>> import numpy as np
>>> truth = np.zeros((2, 3, 3)); pred = truth.copy(); pred[0, 1] = [0.003, 0.004, 0.0]
>>> lve = lip_vertex_error(pred, truth, np.array([0, 1]))
>>> round(lve.mm, 6), round(lve.squared, 9)
(2.5, 1.25e-05)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.errors import InputError


@dataclass(frozen=True)
class LipVertexError:
    """``mm``: mean over frames of the largest lip-vertex distance (millimetres);
    ``squared``: the same of the squared distance, in the file's units squared."""

    mm: float
    squared: float


@dataclass(frozen=True)
class UpperFaceDynamics:
    """``mm``: mean over upper-face vertices of (sd over time of the ground truth's
    displacement norm) minus (the prediction's), millimetres; ``squared``: the same with the
    squared norm, file units squared."""

    mm: float
    squared: float


def _paired(pred: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p, t = np.asarray(pred, dtype=np.float64), np.asarray(truth, dtype=np.float64)
    if p.ndim != 3 or t.ndim != 3 or p.shape[1:] != t.shape[1:]:
        raise InputError(
            f"the prediction {p.shape[1:]} and the ground truth {t.shape[1:]} are not one topology",
            field="ground_truth",
        )
    n = min(len(p), len(t))
    if n == 0:
        raise InputError("no frames to compare", field="ground_truth")
    return p[:n], t[:n]


def lip_vertex_error(
    pred: np.ndarray, truth: np.ndarray, lips: np.ndarray, scale: float = 1.0
) -> LipVertexError:
    """LVE of ``pred`` against ``truth`` ((T, V, 3), metres) over the ``lips`` vertices;
    ``scale``: metres per file unit (for :attr:`LipVertexError.squared`)."""
    p, t = _paired(pred, truth)
    sq = np.sum((p[:, lips] - t[:, lips]) ** 2, axis=2).max(axis=1)  # (T,)
    return LipVertexError(
        mm=float(np.sqrt(sq).mean() * 1000.0), squared=float(sq.mean() / scale**2)
    )


def upper_face_dynamics(
    pred: np.ndarray,
    truth: np.ndarray,
    template: np.ndarray,
    upper: np.ndarray,
    scale: float = 1.0,
) -> UpperFaceDynamics:
    """FDD of ``pred`` against ``truth`` over the ``upper`` vertices, both measured from the
    ground truth's ``template`` (V, 3); metres in, see :class:`UpperFaceDynamics` out."""
    p, t = _paired(pred, truth)
    base = np.asarray(template, dtype=np.float64)[upper]
    sq_p = np.sum((p[:, upper] - base) ** 2, axis=2)
    sq_t = np.sum((t[:, upper] - base) ** 2, axis=2)
    squared = float(np.mean(sq_t.std(axis=0) - sq_p.std(axis=0)) / scale**2)
    mm = float(np.mean(np.sqrt(sq_t).std(axis=0) - np.sqrt(sq_p).std(axis=0)) * 1000.0)
    return UpperFaceDynamics(mm=mm, squared=squared)


def field_measures(
    pred: np.ndarray,
    truth: np.ndarray,
    template: np.ndarray,
    lips: np.ndarray,
    upper: np.ndarray,
    *,
    scale: float,
) -> dict[str, float]:
    """LVE and FDD as a condition's ``measures["mesh"]`` in ``summary.json``: the numbers the
    objective regression reads (:func:`app.analysis.objective.flatten_measures`); what they
    were computed on goes beside them, outside the measures (:mod:`app.stimuli.meshes.summary`)."""
    lve = lip_vertex_error(pred, truth, lips, scale)
    fdd = upper_face_dynamics(pred, truth, template, upper, scale)
    return {
        "lve_mm": lve.mm,
        "lve_squared": lve.squared,
        "fdd_mm": fdd.mm,
        "fdd_squared": fdd.squared,
    }
