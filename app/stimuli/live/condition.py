"""The ``live_gmm`` prosody condition: head, gaze and eyelids by Le, Ma & Deng 2012 (sec. 5-7).

A condition in the sense of :mod:`app.stimuli.conditions`: ``.fit(features, ground_truth)``
trains a :class:`~app.stimuli.live.model.LiveModel`; ``.generate(features, seed=...)`` runs the
streaming generator over the whole file (the offline path is the streaming code). Without
``fit`` it uses the model at ``model_path``, or the one trained on the demo reference speaker
that ships with the project (:data:`DEFAULT_MODEL_PATH`).

Example
-------
>>> import numpy as np
>>> from app.stimuli.speech import SpeechFeatures
>>> t = np.arange(150) / 25.0                      # 6 s of a voice gliding 100-140 Hz
>>> f0 = 120 + 20 * np.sin(np.pi * t)
>>> features = SpeechFeatures(25.0, f0, 60 + 5 * np.sin(t), f0)
>>> track = LiveGmmCondition().generate(features, seed=3)
>>> track.n_frames, track.channels                 # eyes, brows (at rest) and head
(150, (19, 20, 21, 22, 23, 24, 25, 26, 31, 32, 33, 34, 35, 36, 37, 38, 48, 49, 50))
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from app.data import data_path
from app.errors import InputError
from app.stimuli.conditions.base import ConditionModel
from app.stimuli.live.stream import OUTPUT_CHANNELS
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack

if TYPE_CHECKING:
    from app.stimuli.live.model import LiveModel

#: The model trained on the demo reference speaker (rebuild command in docs/reference/live.md).
DEFAULT_MODEL_PATH = data_path("models", "live_gmm_default.npz")


class LiveGmmCondition(ConditionModel):
    """Speech-driven head (GMMs + gradient ascent), NDCCA gaze and eyelids, frame by frame.

    The track has the model's FAPs 19-26 and 48-50, the neutral eyebrows of every condition and,
    given a ground truth, its jaw and lips (carried as in all conditions, thesis sec. 4.3).
    """

    name = "live_gmm"
    display_name = "LIVE_GMM"

    def __init__(
        self, *, model_path: str | Path | None = None, n_components: int = 10, train_seed: int = 0
    ) -> None:
        self.model_path = Path(model_path) if model_path is not None else None
        self.n_components = n_components
        self.train_seed = train_seed
        self.model: LiveModel | None = None
        self._fitted = False
        self.note = (
            "model read from the given model file"
            if model_path is not None
            else "shipped default model (demo reference speaker)"
        )

    def fit(self, features: SpeechFeatures, ground_truth: MotionTrack | None) -> LiveGmmCondition:
        """Train on speech features and a ground-truth track with head motion (FAPs 48-50;
        gaze 23-26 and eyelids 19-22 are used when present).

        A no-op, keeping the file model, when a ``model_path`` was given (an explicit model is
        used instead of fitting), when there is no ground truth, or when the ground truth
        cannot be trained on (no moving head, fewer than 100 frames); :meth:`describe` and the
        track's metadata say which model was used and why.
        """
        from app.stimuli.live.model import train_live_model

        if ground_truth is None:
            return self
        if self.model_path is not None:
            self.note = "model read from the given model file (not fitted)"
            return self
        try:
            self.model = train_live_model(
                features, ground_truth, n_components=self.n_components, seed=self.train_seed
            )
        except InputError as exc:
            self.note = f"ground truth not usable for training ({exc.message}): default model"
            return self
        self._fitted = True
        self.note = "model fitted on the ground truth of this recording"
        return self

    def _loaded(self) -> LiveModel:
        if self.model is None:
            from app.stimuli.live.modelfile import load_model

            path = self.model_path or DEFAULT_MODEL_PATH
            if not path.exists():
                raise InputError(
                    "live model file not found (train one with `facepair stimuli "
                    "train-live`, see docs/reference/live.md)",
                    path=path,
                )
            self.model = load_model(path)
        return self.model

    def generate(
        self, features: SpeechFeatures, *, seed: int = 0, ground_truth: MotionTrack | None = None
    ) -> MotionTrack:
        """FAPs 19-26 and 48-50 for ``features``: the model sees speech only; the ground truth
        only supplies the jaw and lips carried into every condition's track."""
        from app.stimuli.live.stream import generate_track

        model = self._loaded()
        live = generate_track(model, features, seed=seed, name=self.name)
        base = self.base_track(features, ground_truth)
        track = base.with_channels({c: live[c] for c in OUTPUT_CHANNELS})
        meta = {
            **base.metadata,
            **live.metadata,
            "model_note": self.note,
            "model_path": "fitted" if self._fitted else str(self.model_path or DEFAULT_MODEL_PATH),
        }
        return track.replace(metadata=meta)

    def describe(self) -> dict[str, Any]:
        """Model facts for the generation summary: where it came from and its training data."""
        model = self.model
        return {
            "model": "fitted" if self._fitted else str(self.model_path or DEFAULT_MODEL_PATH),
            "note": self.note,
            "training": None if model is None else model.summary,
        }
