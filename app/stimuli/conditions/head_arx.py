"""The speech-driven head model: an ARX system from speech contours to head pitch, yaw, roll.

Thesis sec. 4.3.4.2: na = 4, nb = 4, nk = 1; inputs the speech energy (intensity, dB), the
conditioned F0, their product (a simple non-linear effect) and the energy and F0 contours
mean-filtered over 1 second (two time scales); outputs FAP 48-50; each output also regresses on
the previous outputs of all three angles. Inputs are standardised with the training means and
standard deviations, which the model keeps, so a model transfers between recordings of one
speaker whose level differs a little.

A model fitted on a short recording can be explosive when run free; the fit therefore raises
the ridge penalty (1e-4, 1e-3, ... 1) until the AR part is stable (spectral radius < 0.995)
and reports what it used.

Models are saved as JSON (``format: facepair-head-arx``). facepair ships one fitted on the demo
data, :data:`DEFAULT_MODEL_PATH`, used when a speech-driven track is asked for without ground
truth; regenerate it with ``facepair stimuli fit-head-model`` (see ``docs/reference/stimuli.md``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.data import data_path
from app.errors import InputError
from app.stimuli.arx import ArxModel, fit_arx
from app.stimuli.fap import HEAD
from app.stimuli.speech import SpeechFeatures, smooth_1s
from app.stimuli.track import MotionTrack

HEAD_INPUTS = (
    "intensity_db",
    "f0_conditioned_hz",
    "intensity_x_f0",
    "intensity_db_1s_mean",
    "f0_conditioned_hz_1s_mean",
)
DEFAULT_MODEL_PATH = data_path("models", "head_arx_default.json")
FORMAT = "facepair-head-arx"
_STABLE = 0.995
_RIDGES = (1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0)
#: How generation standardises the speech inputs (see :meth:`HeadPoseArx.generate`).
INPUT_NORMS = ("recording", "model")


def free_run_error(model: ArxModel, y: np.ndarray, z: np.ndarray) -> float:
    """Mean over angles of the free-run error of the centred motion, in units of each angle's
    sd: ``rms((sim - mean sim) - (y - mean y)) / sd(y)``, with ``sim`` run from rest as in
    generation (0: perfect; 1: no better than holding the mean)."""
    sim = model.simulate(z, from_rest=True)
    dev = (sim - sim.mean(axis=0)) - (y - y.mean(axis=0))
    sd = np.where(y.std(axis=0) > 0, y.std(axis=0), 1.0)
    return float(np.mean(np.sqrt(np.mean(dev**2, axis=0)) / sd))


def _select_ridge(
    y: np.ndarray, z: np.ndarray, order: dict[str, int], ridge: float
) -> tuple[ArxModel | None, float]:
    """The stable fit (spectral radius < 0.995) with the smallest :func:`free_run_error` over
    ``ridge`` and the larger ridges of :data:`_RIDGES`.

    The thesis fits by least squares on the one-step equation error; on a short recording
    such a fit can be stable and still free-run far from the data (a near-integrating AR part
    turns a speech onset into a slow drift of several degrees), so the ridge is chosen by the
    error of the motion the model will actually generate.
    """
    best: tuple[ArxModel | None, float] = (None, float("inf"))
    for r in (ridge, *[r for r in _RIDGES if r > ridge]):
        model = fit_arx(y, z, ridge=r, **order)
        if model.spectral_radius() >= _STABLE:
            continue
        err = free_run_error(model, y, z)
        if err < best[1]:
            model.info["ridge_selected"] = r
            best = (model, err)
    return best


def head_inputs(features: SpeechFeatures) -> np.ndarray:
    """The thesis' five ARX inputs per frame, shape (n_frames, 5), in :data:`HEAD_INPUTS` order."""
    inten = np.asarray(features.intensity, dtype=np.float64)
    f0 = np.asarray(features.f0_conditioned, dtype=np.float64)
    return np.column_stack(
        [inten, f0, inten * f0, smooth_1s(inten, features.fps), smooth_1s(f0, features.fps)]
    )


@dataclass(eq=False)
class HeadPoseArx:
    """An ARX head model with its input standardisation and frame rate."""

    arx: ArxModel
    input_mean: np.ndarray
    input_std: np.ndarray
    fps: float
    outputs: tuple[int, ...] = HEAD
    provenance: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def fit(
        cls,
        features: SpeechFeatures,
        ground_truth: MotionTrack,
        *,
        na: int = 4,
        nb: int = 4,
        nk: int = 1,
        ridge: float = 0.0,
    ) -> HeadPoseArx:
        """Least-squares fit on ``ground_truth`` head angles (already on the features' frames)."""
        u = head_inputs(features)
        mean, std = u.mean(axis=0), u.std(axis=0)
        std = np.where(std > 0, std, 1.0)
        y = np.column_stack([ground_truth.get(c) for c in HEAD])
        if len(y) != len(u):
            raise ValueError(f"ground truth has {len(y)} frames, features {len(u)}")
        z = (u - mean) / std
        try:
            model, err = _select_ridge(y, z, dict(na=na, nb=nb, nk=nk), ridge)
        except ValueError as exc:
            raise InputError(f"cannot fit the head model: {exc}", field="ground_truth") from None
        note = ""
        if model is None:  # no stable dynamics found: keep the static input response
            model = fit_arx(y, z, na=na, nb=nb, nk=nk, ridge=ridge)
            model.a[:] = 0.0
            note = "AR part dropped: no ridge gave a stable model"
        sim = model.simulate(z)
        model.info.update(
            spectral_radius=model.spectral_radius(),
            note=note,
            free_run_rmse=np.sqrt(np.mean((sim - y) ** 2, axis=0)).tolist(),
            free_run_error=err,
        )
        prov = {
            "fitted_on": "ground truth",
            "audio": features.metadata.get("audio", ""),
            "ground_truth_source": ground_truth.source,
            "frames": len(y),
        }
        return cls(model, mean, std, float(features.fps), HEAD, prov)

    def generate(
        self,
        features: SpeechFeatures,
        *,
        input_norm: str = "recording",
        mean: Mapping[int, float] | None = None,
    ) -> dict[int, np.ndarray]:
        """Free-running head angles for ``features`` ({fap: column}).

        The head starts at rest and moves only with the speech's changes from the first frame
        (:meth:`ArxModel.simulate` ``from_rest``), so it does not swing in the silence before
        speech. ``input_norm``:
        ``"recording"`` standardises the inputs with this recording's own means and standard
        deviations (a voice louder or higher than the training voice then drives the head as
        much, not with a constant offset), ``"model"`` with the training ones. Each angle is
        then shifted to ``mean[fap]`` (default 0, the neutral pose): the model contributes the
        motion, never a per-speaker posture.
        """
        if input_norm not in INPUT_NORMS:
            raise InputError(
                f"input_norm must be one of {', '.join(INPUT_NORMS)}, got {input_norm!r}",
                field="input_norm",
            )
        u = head_inputs(features)
        n = features.n_frames
        if n == 0:
            return {c: np.zeros(0) for c in self.outputs}
        if features.fps != self.fps:  # the lags are in frames: run at the model's own rate
            m = round(n * self.fps / features.fps)
            t_model, t_feat = np.arange(m) / self.fps, np.arange(n) / features.fps
            u = np.column_stack([np.interp(t_model, t_feat, col) for col in u.T])
        if input_norm == "recording":
            mu, sd = u.mean(axis=0), u.std(axis=0)
            sd = np.where(sd > 0, sd, 1.0)
        else:
            mu, sd = self.input_mean, self.input_std
        y = self.arx.simulate((u - mu) / sd, from_rest=True)
        if features.fps != self.fps:
            track = MotionTrack(self.fps, y, self.outputs).resample(features.fps, n)
            y = track.values
        target = mean or {}
        return {
            c: y[:, j] - y[:, j].mean() + float(target.get(c, 0.0))
            for j, c in enumerate(self.outputs)
        }

    # -- persistence --------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "version": 1,
            "fps": self.fps,
            "inputs": list(HEAD_INPUTS),
            "outputs": list(self.outputs),
            "input_mean": self.input_mean.tolist(),
            "input_std": self.input_std.tolist(),
            "arx": self.arx.to_dict(),
            "provenance": self.provenance,
        }

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=1) + "\n", encoding="utf-8")

    @classmethod
    def load(cls, path: str | Path) -> HeadPoseArx:
        """Read a model saved by :meth:`save`; a wrong or damaged file is an InputError."""
        try:
            d = json.loads(Path(path).read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise InputError("no such head model file", path=path) from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"not a JSON head model: {exc}", path=path) from None
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise InputError(f"not a facepair head model (expected format {FORMAT!r})", path=path)
        try:
            if list(d["inputs"]) != list(HEAD_INPUTS):
                raise ValueError(f"inputs {d['inputs']} differ from {list(HEAD_INPUTS)}")
            arx = ArxModel.from_dict(d["arx"])
            mean, std = np.asarray(d["input_mean"], float), np.asarray(d["input_std"], float)
            if arx.n_in != len(HEAD_INPUTS) or mean.shape != (arx.n_in,) or std.shape != mean.shape:
                raise ValueError("input sizes disagree")
            return cls(
                arx,
                mean,
                std,
                float(d["fps"]),
                tuple(int(c) for c in d["outputs"]),
                dict(d.get("provenance", {})),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"damaged head model: {exc}", path=path) from None
