"""The validated form of a study: what a study file or the web form describes.

Dataclasses only, plus the derived design quantities (pairs, number of lists, a participant's
schedule); reading and validating the TOML file is :mod:`app.trials.studyfile`. The fields follow
the seeds' experiments: conditions (thesis sec. 5.2: NO_PROSODY, RANDOM, SPEECH_DRIVEN,
GROUND_TRUTH), clips (the thesis' segments S2 and S7; the 2012 paper's ten audio clips, sec.
8.1.1), the question (thesis sec. 5.2), the pair design, the undecided option (Le et al. 2012,
sec. 8.1) and the replay policy.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

from app.stimuli.eyes import DEFAULT_EYES
from app.stimuli.posture import DEFAULT_POSTURE
from app.trials.design import RATING_DESIGNS, ConditionPair, build_pairs
from app.trials.fields import key_text
from app.trials.participation import ParticipationSpec
from app.trials.questions import QuestionSpec
from app.trials.rating import DEFAULT_RATING_SCALE
from app.trials.recruiting import RecruitingSpec
from app.trials.rules import DEFAULT_UNDECIDED_LABEL, ReplayPolicy
from app.trials.schedule import make_schedule, n_lists_for
from app.trials.stimuli import shown_stimuli, variant_stimuli
from app.trials.trial import ScheduledTrial

KNOWN_MODELS: Final = ("none", "random", "speech_driven", "ground_truth", "live_gmm")
"""The models of the stimulus engine's interface; every one must be a key of
``app.stimuli.conditions.CONDITIONS`` (the tests check it when that module is present)."""


def _registered_models() -> tuple[str, ...]:
    """Model names from the stimulus engine's registry, the one place for them, if installed."""
    try:
        from app.stimuli.conditions import CONDITIONS
    except ImportError:
        return KNOWN_MODELS
    return tuple(CONDITIONS)


MODELS: Final[tuple[str, ...]] = _registered_models()
"""Model names a condition may use."""


@dataclass(frozen=True, slots=True)
class ConditionSpec:
    """One experimental condition: a model with settings, or uploaded tracks, one per clip.

    ``model`` names an entry of ``app.stimuli.conditions.CONDITIONS`` and ``settings`` are its
    keyword parameters (``make_condition(model, **settings)``); with ``tracks`` (clip name ->
    ``.fap``/``.csv`` path) the condition is an uploaded motion track per clip and ``model`` is
    ``None``; ``mesh`` says how its mesh or FLAME files are read, over the study's ``meshes``
    (:mod:`app.trials.meshtables`).
    """

    name: str
    model: str | None = None
    settings: Mapping[str, Any] = field(default_factory=dict)
    tracks: Mapping[str, Path] = field(default_factory=dict)
    mesh: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class ClipSpec:
    """One speech segment: its audio and, optionally, the captured (ground-truth) motion."""

    name: str
    audio: Path
    ground_truth: Path | None = None


@dataclass(frozen=True, slots=True)
class StudySpec:
    """A validated study; see ``docs/reference/studyfile.md`` for the meaning of every field."""

    title: str
    question: str
    conditions: tuple[ConditionSpec, ...]
    clips: tuple[ClipSpec, ...]
    instructions: str = ""
    consent: str = ""
    design: str = "all_ordered"
    reference: str | None = None
    undecided_allowed: bool = True
    undecided_label: str = DEFAULT_UNDECIDED_LABEL
    replay: ReplayPolicy = field(default_factory=ReplayPolicy)
    catch_trials: int = 0
    catch_kind: str = "identical"
    target_participants: int = 20
    completion_code: str = ""
    redirect_url: str | None = None
    seed: int = 0
    practice: ConditionPair | None = None
    practice_clip: str | None = None
    block_by_clip: bool = True
    eyes: str = DEFAULT_EYES
    #: Head rest posture of the conditions (:mod:`app.stimuli.posture`): ``shared`` or
    #: ``per_condition`` (the thesis' experiment 1).
    posture: str = DEFAULT_POSTURE
    #: The jaw, lips and rest of the lower face (:mod:`app.stimuli.shared`): ``shared``,
    #: ``own``, or None: shared under the mouth mosaic, each condition's own without it.
    lips: str | None = None
    #: The eyebrows (:mod:`app.stimuli.shared`): each condition's own, none, or the rule's.
    brows: str = "own"
    #: How the study's mesh and FLAME sequences are read (:mod:`app.trials.meshtables`).
    meshes: Mapping[str, Any] = field(default_factory=dict)
    #: The eyes beside a mesh condition (:mod:`app.stimuli.meshes.fairness`).
    mesh_eyes: str = "match"
    #: Whether a ground truth or imported track longer or shorter than its speech beyond
    #: :data:`app.stimuli.lengths.LENGTH_TOLERANCE_S` is padded or cut instead of refused.
    pad: bool = False
    normalize: bool = False
    render: Mapping[str, Any] = field(default_factory=dict)
    exclude: str = ""
    rejoin: str = "resume"
    participation: ParticipationSpec = field(default_factory=ParticipationSpec)
    #: The ``rating`` design's scale (:data:`app.trials.rating.RATING_SCALES`).
    rating_scale: str = DEFAULT_RATING_SCALE
    # -- the experimenter's side --
    #: Automatic exclusion rules the report applies (``app.web.study.participants.AUTO_RULES``).
    auto_exclude: tuple[str, ...] = ("catch_failed", "unfinished")
    #: Questionnaire pages before and after the trials (:mod:`app.trials.questions`).
    questions: tuple[QuestionSpec, ...] = ()
    #: The ``[prolific]`` table (:mod:`app.trials.recruiting`), if the study recruits through
    #: facepair's Prolific client.
    prolific: RecruitingSpec | None = None

    @property
    def condition_names(self) -> list[str]:
        """Condition names in file order."""
        return [c.name for c in self.conditions]

    @property
    def clip_names(self) -> list[str]:
        """Clip names in file order."""
        return [c.name for c in self.clips]

    def pairs(self) -> list[ConditionPair]:
        """The design's pairs (:func:`app.trials.design.build_pairs`)."""
        return build_pairs(self.condition_names, self.design, reference=self.reference)

    def n_lists(self) -> int:
        """Lists in one counterbalancing cycle (:func:`app.trials.schedule.n_lists_for`)."""
        return n_lists_for(
            self.design,
            n_clips=len(self.clips),
            block_by_clip=self.block_by_clip,
            n_conditions=len(self.conditions),
        )

    def stimuli(self) -> list[tuple[str, ConditionPair]]:
        """Every (clip name, displayed pair) some schedule shows: the side-by-side clips to render
        (:func:`app.trials.stimuli.shown_stimuli`)."""
        return shown_stimuli(
            clips=self.clip_names,
            pairs=self.pairs(),
            design=self.design,
            catch_trials=self.catch_trials,
            catch_kind=self.catch_kind,
            practice_pair=self.practice,
            practice_clip=self.practice_clip,
        )

    def variants(self) -> list[tuple[str, ConditionPair, str, str]]:
        """Attention-check and appropriateness clips to render besides :meth:`stimuli`
        (:func:`app.trials.stimuli.variant_stimuli`)."""
        return variant_stimuli(
            clips=self.clip_names,
            pairs=self.pairs(),
            design=self.design,
            catch_trials=self.catch_trials,
            catch_kind=self.catch_kind,
            mismatched=self.participation.mismatched,
        )

    def schedule(self, *, seed: int, list_index: int) -> list[ScheduledTrial]:
        """One participant's schedule from their stored seed and assigned list."""
        return make_schedule(
            clips=self.clip_names,
            pairs=self.pairs(),
            design=self.design,
            seed=seed,
            list_index=list_index,
            n_lists=self.n_lists(),
            catch_trials=self.catch_trials,
            practice_pair=self.practice,
            catch_kind=self.catch_kind,
            practice_clip=self.practice_clip,
            block_by_clip=self.block_by_clip,
            mismatched=self.participation.mismatched,
            reference=self.reference,
        )

    def to_dict(self) -> dict[str, Any]:
        """The study as a study-file mapping (paths as strings), e.g. to store as JSON.

        ``app.trials.studyfile.parse_study(spec.to_dict())`` gives back an equal spec.
        """
        out: dict[str, Any] = {
            "title": self.title,
            "question": self.question,
            "instructions": self.instructions,
            "consent": self.consent,
            "design": self.design,
        }
        if self.reference is not None:
            out["reference"] = self.reference
        out |= {
            "seed": self.seed,
            "target_participants": self.target_participants,
            "completion_code": self.completion_code,
        }
        if self.redirect_url is not None:
            out["redirect_url"] = self.redirect_url
        out["block_by_clip"] = self.block_by_clip
        out["eyes"] = self.eyes
        if self.posture != DEFAULT_POSTURE:
            out["posture"] = self.posture
        if self.lips is not None:
            out["lips"] = self.lips
        if self.brows != "own":
            out["brows"] = self.brows
        if self.pad:
            out["pad"] = True
        if self.meshes:
            out["meshes"] = dict(self.meshes)
        if self.mesh_eyes != "match":
            out["mesh_eyes"] = self.mesh_eyes
        out["normalize"] = self.normalize
        out["rejoin"] = self.rejoin
        out["auto_exclude"] = list(self.auto_exclude)
        if self.render:
            out["render"] = {k: str(v) if k == "face" else v for k, v in self.render.items()}
        if self.exclude:
            out["exclude"] = self.exclude
        out["practice"] = (
            False if self.practice is None else [self.practice.left, self.practice.right]
        )
        if self.practice_clip is not None:
            out["practice_clip"] = self.practice_clip
        out["undecided"] = {"allowed": self.undecided_allowed, "label": self.undecided_label}
        out["replay"] = {"policy": self.replay.kind}
        if self.replay.max_plays is not None:
            out["replay"]["max_plays"] = self.replay.max_plays
        out["catch"] = {"trials": self.catch_trials, "kind": self.catch_kind}
        out |= self.participation.to_dict()
        if self.design in RATING_DESIGNS:
            out["rating"] = {"scale": self.rating_scale}
        out["conditions"] = [_condition_dict(c) for c in self.conditions]
        out["clips"] = [_clip_dict(c) for c in self.clips]
        if self.questions:
            out["questions"] = [q.to_dict() for q in self.questions]
        if self.prolific is not None:
            out["prolific"] = self.prolific.to_dict()
        return out

    def to_toml(self) -> str:
        """The study as TOML text that ``app.trials.studyfile.loads_study`` reads back."""
        return dump_toml(self.to_dict())

    def to_portable_toml(self) -> str:
        """:meth:`to_toml` with every file named by its file name alone: a study made on the
        web form, kept as the file it amounts to (no server folder in it); uploaded with the
        same files it is the same study, as uploads are matched by name."""
        document = self.to_dict()
        for clip in document["clips"]:
            for key in ("audio", "ground_truth"):
                if key in clip:
                    clip[key] = Path(clip[key]).name
        for condition in document["conditions"]:
            if "tracks" in condition:
                condition["tracks"] = {c: Path(p).name for c, p in condition["tracks"].items()}
        if "face" in document.get("render", {}):
            document["render"]["face"] = Path(document["render"]["face"]).name
        return dump_toml(document)


def _condition_dict(condition: ConditionSpec) -> dict[str, Any]:
    out: dict[str, Any] = {"name": condition.name}
    if condition.tracks:
        out["tracks"] = {clip: str(path) for clip, path in condition.tracks.items()}
        if condition.mesh:
            out["mesh"] = dict(condition.mesh)
    else:
        out["model"] = condition.model
        if condition.settings:
            out["settings"] = dict(condition.settings)
    return out


def _clip_dict(clip: ClipSpec) -> dict[str, Any]:
    out: dict[str, Any] = {"name": clip.name, "audio": str(clip.audio)}
    if clip.ground_truth is not None:
        out["ground_truth"] = str(clip.ground_truth)
    return out


def dump_toml(document: Mapping[str, Any]) -> str:
    """Write a study-file mapping as TOML: plain keys, then tables, then arrays of tables.

    Covers the value types a study file holds (strings, integers, floats, booleans, arrays and
    nested tables inside ``settings``); strings use JSON escapes, which TOML basic strings share.

    >>> print(dump_toml({"title": "A", "replay": {"policy": "unlimited"}}), end="")
    title = "A"
    <BLANKLINE>
    [replay]
    policy = "unlimited"
    """
    lines: list[str] = []
    tables = {k: v for k, v in document.items() if isinstance(v, Mapping)}
    arrays = {
        k: v
        for k, v in document.items()
        if isinstance(v, list) and v and all(isinstance(i, Mapping) for i in v)
    }
    for key, value in document.items():
        if key not in tables and key not in arrays:
            lines.append(f"{key_text(key)} = {_value(value)}")
    for key, table in tables.items():
        lines += ["", f"[{key_text(key)}]"] + [
            f"{key_text(k)} = {_value(v)}" for k, v in table.items()
        ]
    for key, items in arrays.items():
        for item in items:
            lines += ["", f"[[{key_text(key)}]]"]
            lines += [f"{key_text(k)} = {_value(v)}" for k, v in item.items()]
    return "\n".join(lines) + "\n"


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{key_text(k)} = {_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")
