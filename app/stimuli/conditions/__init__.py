"""The experimental conditions: models that turn speech (and ground truth) into motion tracks.

Thesis sec. 4.3: NO_PROSODY, RANDOM, SPEECH_DRIVEN and GROUND_TRUTH; LIVE_GMM is the live
speech-driven head and eye model of Le, Ma & Deng (2012), built in ``app.stimuli.live``.

The registry maps a condition name to an import path ``"module:Class"`` that is imported only
when the condition is made, so a condition whose module (or its dependencies) is absent fails
with one clear line instead of breaking every import. Each condition has ``.name``,
``.fit(features, ground_truth) -> self`` and ``.generate(features, *, seed=0,
ground_truth=None) -> MotionTrack``, deterministic for a given seed.

Example
-------
>>> make_condition("none").name
'none'
>>> DISPLAY_NAMES["speech_driven"]
'SPEECH_DRIVEN'
"""

from __future__ import annotations

import importlib
from typing import Any

from app.errors import InputError
from app.stimuli.conditions.base import ConditionModel
from app.stimuli.conditions.names import DISPLAY_NAMES

#: Condition name -> "module:Class" (imported lazily by :func:`make_condition`).
CONDITIONS: dict[str, str] = {
    "none": "app.stimuli.conditions.none:NoProsodyCondition",
    "random": "app.stimuli.conditions.random_prosody:RandomCondition",
    "speech_driven": "app.stimuli.conditions.speech_driven:SpeechDrivenCondition",
    "ground_truth": "app.stimuli.conditions.ground_truth:GroundTruthCondition",
    "live_gmm": "app.stimuli.live.condition:LiveGmmCondition",
}

#: The condition made from a file rather than chosen by name: a track a researcher brings
#: (:mod:`app.stimuli.conditions.imported`); not a model a study file names.
IMPORTED = "imported"
_IMPORTED_CLASS = "app.stimuli.conditions.imported:ImportedCondition"

__all__ = [
    "CONDITIONS",
    "DISPLAY_NAMES",
    "IMPORTED",
    "ConditionModel",
    "condition_class",
    "make_condition",
]


def condition_class(name: str) -> type[ConditionModel]:
    """Import and return the class registered under ``name`` (InputError if unknown/absent)."""
    where = _IMPORTED_CLASS if name == IMPORTED else CONDITIONS.get(name)
    if where is None:
        raise InputError(
            f"unknown condition {name!r}: expected one of {', '.join(CONDITIONS)}",
            field="conditions",
        )
    module_name, _, class_name = where.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        missing = exc.name or module_name
        raise InputError(
            f"condition {name!r} is not available in this installation: module {missing!r} "
            f"is missing (needed by {module_name})",
            field="conditions",
        ) from None
    try:
        return getattr(module, class_name)
    except AttributeError:
        raise InputError(
            f"condition {name!r}: {module_name} defines no {class_name}", field="conditions"
        ) from None


def make_condition(name: str, **params: Any) -> ConditionModel:
    """A new condition model by registry name, with its parameters.

    Unknown names, missing modules and parameters the condition does not take give an
    :class:`InputError` naming the condition.
    """
    cls = condition_class(name)
    try:
        return cls(**params)
    except TypeError as exc:
        raise InputError(f"condition {name!r}: {exc}", field="conditions") from None
