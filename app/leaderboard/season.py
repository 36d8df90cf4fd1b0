"""Season files: one TOML file describing a leaderboard season.

A season is a benchmark set (N speech segments, each with its transcript and captured ground
truth), one frozen render setting (``[render]``: the study file's keys: head or avatar, size,
mosaic, frame rate) and frozen test settings (``[test]``: the study file's keys a leaderboard
does not fix itself: question, consent, eyes, posture, lips, brows, catch trials, exclusion
rules, language, ...), plus the leaderboard's own rules (``[rounds]``, ``[submissions]``,
``[publish]``). Every key is in ``docs/guide/leaderboard.md``; ``[render]`` and ``[test]`` are
checked by the study file's own reader (:func:`app.trials.studyfile.parse_study`) on the round
study they will make, so a season refuses exactly what a round study would.

Its manifest, the frozen state by SHA-256, is :mod:`app.leaderboard.manifest`'s.

Every mistake is one :class:`~app.errors.InputError` line naming the file and the field::

    season.toml: segments[1].transcript: missing (required)
    season.toml: test.eyes: expected one of still, ground_truth, generated, own, got 'x'
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

from app.errors import InputError
from app.stimuli.fap import EYEBROWS, EYELIDS, GAZE, HEAD, JAW_LIPS
from app.trials.fields import FieldReader, describe
from app.trials.stimulusside import AUDIO_SUFFIXES, TRACK_SUFFIXES
from app.trials.studyfile import MODELS, parse_study

TOP_KEYS: Final = (
    "name",
    "title",
    "organiser",
    "seed",
    "description",
    "licence",
    "segments",
    "render",
    "test",
    "rounds",
    "submissions",
    "publish",
)
#: Study-file keys the leaderboard sets itself in every round study, so ``[test]`` may not.
FIXED_STUDY_KEYS: Final = (
    "title",
    "design",
    "reference",
    "seed",
    "conditions",
    "clips",
    "practice",
    "practice_clip",
    "mismatched",
    "rating",
    "render",
    "block_by_clip",
    "normalize",
    "target_participants",
)
#: ``[test]`` keys that decide how the tracks are made, which a system's preview shares with
#: the rounds (so the preview shows what participants will see).
STIMULUS_KEYS: Final = ("eyes", "posture", "lips", "brows", "pad")
#: The answer scale of the naturalness test: HEMVIP2's five levels, always.
ANSWER_SCALE: Final = 5
DEFAULT_QUESTION: Final = "Which face's motion looks more natural with this speech?"
DEFAULT_INSTRUCTIONS: Final = (
    "You will see pairs of talking faces saying the same sentence; the mouths are blurred on "
    "purpose. Watch each pair to the end, then say which face moves more naturally with the "
    "speech, and how clearly. In some pairs both faces come from the same animation and one "
    "of them moves to another sentence: choose the one that fits what you hear."
)
#: The channel groups a track may carry, as submission checks report them (FAP numbers).
CHANNEL_GROUPS: Final[dict[str, tuple[int, ...]]] = {
    "head": HEAD,
    "eyebrows": EYEBROWS,
    "eyes": GAZE,
    "eyelids": EYELIDS,
    "jaw_lips": JAW_LIPS,
}
#: Frame rates a submitted track may have when the season names none (frames per second).
FRAME_RATE_RANGE: Final = (10.0, 240.0)


@dataclass(frozen=True, slots=True)
class SegmentSpec:
    """One benchmark segment: its speech, what is said, and the captured motion (secret)."""

    name: str
    audio: Path
    ground_truth: Path
    transcript: str


@dataclass(frozen=True, slots=True)
class RoundRules:
    """What every round takes: the fixed anchors (stimulus models, in every round), how many
    current top systems join them as anchors, how many segments (0: all), how many pairs
    (0: automatic, :func:`app.leaderboard.pairing.pair_budget`) and participants."""

    anchors: tuple[str, ...] = ("ground_truth", "none")
    top: int = 2
    segments: int = 0
    pairs: int = 0
    participants: int = 20


@dataclass(frozen=True, slots=True)
class SubmissionRules:
    """What an upload must be: the frame rates allowed (empty: any in
    :data:`FRAME_RATE_RANGE`), samples per segment at most (stochastic systems), the channel
    groups every track must move, the largest file, and whether a length beyond the 0.2 s
    tolerance is padded or cut (the ``[test]`` table's ``pad``) instead of refused."""

    frame_rates: tuple[float, ...] = ()
    samples: int = 5
    require: tuple[str, ...] = ()
    max_file_mb: int = 20
    pad: bool = False


@dataclass(frozen=True, slots=True)
class PublishRules:
    """How scores are made public: the votes below which a system is preliminary, the
    bootstrap replicates, the interval's confidence and the drift check's level."""

    min_votes: int = 300
    bootstrap: int = 1000
    confidence: float = 0.95
    drift_alpha: float = 0.05


@dataclass(frozen=True, slots=True)
class SeasonSpec:
    """A validated season file; ``render`` and ``test`` are study-file mappings as written
    (paths as strings, resolved against ``base_dir``)."""

    name: str
    title: str
    organiser: str
    segments: tuple[SegmentSpec, ...]
    seed: int = 0
    description: str = ""
    licence: str = "CC-BY-NC-4.0"
    render: Mapping[str, Any] = field(default_factory=dict)
    test: Mapping[str, Any] = field(default_factory=dict)
    rounds: RoundRules = field(default_factory=RoundRules)
    submissions: SubmissionRules = field(default_factory=SubmissionRules)
    publish: PublishRules = field(default_factory=PublishRules)
    base_dir: Path = Path(".")

    @property
    def segment_names(self) -> list[str]:
        return [s.name for s in self.segments]

    def face(self) -> Path | None:
        """The avatar or face file of ``[render] face``, resolved, if any."""
        face = self.render.get("face")
        return None if face is None else (self.base_dir / str(face)).resolve()

    def study_mapping(
        self,
        *,
        title: str,
        seed: int,
        conditions: Sequence[Mapping[str, Any]],
        clips: Sequence[Mapping[str, Any]],
        render: Mapping[str, Any] | None = None,
    ) -> dict[str, Any]:
        """A round study's study-file mapping: the frozen ``[test]`` keys, the frozen
        ``[render]`` (``render`` replaces it, e.g. with the stored avatar's path), the pair
        design whose pairs the round's plan then narrows, HEMVIP2's five levels and the
        appropriateness (mismatched speech) pairs."""
        test = {k: v for k, v in self.test.items()}
        answer = dict(test.pop("answer", {}) or {})
        answer["scale"] = ANSWER_SCALE
        mapping: dict[str, Any] = {
            "title": title,
            "question": DEFAULT_QUESTION,
            "instructions": DEFAULT_INSTRUCTIONS,
            **test,
            "design": "unordered_counterbalanced",
            "seed": seed,
            "practice": False,
            "mismatched": True,
            "answer": answer,
            "target_participants": self.rounds.participants,
            "render": dict(self.render if render is None else render),
            "conditions": list(conditions),
            "clips": list(clips),
        }
        return mapping

    def preview_mapping(
        self,
        *,
        title: str,
        seed: int,
        conditions: Sequence[Mapping[str, Any]],
        clips: Sequence[Mapping[str, Any]],
        render: Mapping[str, Any] | None = None,
    ) -> dict[str, Any]:
        """A single-face study of ``conditions`` on ``clips`` (the rating design, never opened):
        how a system's preview and the anchors' renders are made, with the rounds' render and
        stimulus settings."""
        return {
            "title": title,
            "question": "How natural is the motion of this face?",
            "design": "rating",
            "seed": seed,
            "practice": False,
            **{k: self.test[k] for k in STIMULUS_KEYS if k in self.test},
            "render": dict(self.render if render is None else render),
            "conditions": list(conditions),
            "clips": list(clips),
        }


def load_season_file(path: str | Path, *, check_files: bool = True) -> SeasonSpec:
    """Read and validate a season file; paths in it resolve against its folder."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError("no such season file", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read season file: {exc}", path=path) from None
    return loads_season(text, source=str(path), base_dir=path.parent, check_files=check_files)


def loads_season(
    text: str, *, source: str = "season.toml", base_dir: str | Path = ".", check_files: bool = True
) -> SeasonSpec:
    """Parse and validate season-file text (``source`` names it in errors)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        found = re.search(r"at line (\d+)", str(exc))
        message = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise InputError(
            f"invalid TOML: {message}", path=source, line=int(found.group(1)) if found else None
        ) from None
    except RecursionError:
        raise InputError("invalid TOML: arrays or tables nested too deeply", path=source) from None
    return parse_season(data, source=source, base_dir=base_dir, check_files=check_files)


def parse_season(
    data: Mapping[str, Any],
    *,
    source: str = "season.toml",
    base_dir: str | Path = ".",
    check_files: bool = True,
) -> SeasonSpec:
    """Validate a parsed season file (keys in the order of the guide, so errors come top-down)."""
    reader = FieldReader(source, Path(base_dir), check_files=check_files)
    top = reader.table(data, "", TOP_KEYS)
    name = reader.identifier(top, "name", "name")
    title = reader.text(top, "title", "title", nonempty=True)
    organiser = reader.text(top, "organiser", "organiser", nonempty=True).strip().lower()
    if not re.fullmatch(r"[^@\s]+@[^@\s]+", organiser):
        raise reader.error("organiser", f"expected an experimenter's e-mail, got {organiser!r}")
    seed = reader.integer(top, "seed", "seed", 0, 0)
    description = reader.text(top, "description", "description", "")
    licence = reader.text(top, "licence", "licence", "CC-BY-NC-4.0", nonempty=True)
    segments = _segments(reader, top)
    rounds = _rounds(reader, top.get("rounds", {}), len(segments))
    submissions = _submissions(reader, top.get("submissions", {}), top.get("test", {}))
    publish = _publish(reader, top.get("publish", {}))
    render = _open_table(reader, top.get("render", {}), "render")
    test = _open_table(reader, top.get("test", {}), "test")
    for key in test:
        if key in FIXED_STUDY_KEYS:
            raise reader.error(f"test.{key}", "set by the leaderboard for every round; remove it")
    answer = test.get("answer", {})
    if isinstance(answer, Mapping) and answer.get("scale", ANSWER_SCALE) != ANSWER_SCALE:
        raise reader.error(
            "test.answer.scale",
            f"the naturalness test has five levels; expected {ANSWER_SCALE}, got "
            f"{describe(answer.get('scale'))}",
        )
    spec = SeasonSpec(
        name=name,
        title=title,
        organiser=organiser,
        segments=segments,
        seed=seed,
        description=description,
        licence=licence,
        render=dict(render),
        test=dict(test),
        rounds=rounds,
        submissions=submissions,
        publish=publish,
        base_dir=Path(base_dir),
    )
    _check_as_study(spec, source, check_files)
    return spec


def _open_table(reader: FieldReader, value: Any, name: str) -> Mapping[str, Any]:
    """A table whose keys the study file's reader checks (``[render]``, ``[test]``)."""
    if not isinstance(value, Mapping):
        raise reader.error(name, f"expected a table, got {describe(value)}")
    return value


def _segments(reader: FieldReader, top: Mapping[str, Any]) -> tuple[SegmentSpec, ...]:
    items = reader.get(top, "segments", "segments", (list,), "an array of [[segments]] tables")
    if len(items) < 2:
        raise reader.error(
            "segments",
            f"at least two segments (the coherence test needs another segment's "
            f"motion), got {len(items)}",
        )
    out: list[SegmentSpec] = []
    for i, item in enumerate(items):
        where = f"segments[{i}]"
        table = reader.table(item, where, ("name", "audio", "ground_truth", "transcript"))
        name = reader.identifier(table, "name", f"{where}.name")
        if name in {s.name for s in out}:
            raise reader.error(f"{where}.name", f"repeats the segment {name!r}")
        audio = reader.file(table, "audio", f"{where}.audio", AUDIO_SUFFIXES)
        truth = reader.file(table, "ground_truth", f"{where}.ground_truth", TRACK_SUFFIXES)
        transcript = reader.text(table, "transcript", f"{where}.transcript", nonempty=True)
        out.append(SegmentSpec(name, audio, truth, transcript.strip()))
    return tuple(out)


def _rounds(reader: FieldReader, data: Any, n_segments: int) -> RoundRules:
    keys = ("anchors", "top", "segments", "pairs", "participants")
    table = reader.table(data, "rounds", keys)
    anchors = reader.get(
        table,
        "anchors",
        "rounds.anchors",
        (list,),
        "an array of model names",
        list(RoundRules().anchors),
    )
    if len(anchors) < 2 or not all(isinstance(a, str) for a in anchors):
        raise reader.error(
            "rounds.anchors", "expected at least two model names (the drift check compares them)"
        )
    for anchor in anchors:
        if anchor not in MODELS:
            raise reader.error(
                "rounds.anchors", f"expected models of {', '.join(MODELS)}, got {anchor!r}"
            )
    if len(set(anchors)) != len(anchors):
        raise reader.error("rounds.anchors", "repeats an anchor")
    segments = reader.integer(table, "segments", "rounds.segments", 0, 0, n_segments)
    if segments == 1:
        raise reader.error("rounds.segments", "0 (all) or at least 2 (the coherence test)")
    return RoundRules(
        anchors=tuple(anchors),
        top=reader.integer(table, "top", "rounds.top", 2, 0, 20),
        segments=segments,
        pairs=reader.integer(table, "pairs", "rounds.pairs", 0, 0, 10_000),
        participants=reader.integer(table, "participants", "rounds.participants", 20, 1, 100_000),
    )


def _submissions(reader: FieldReader, data: Any, test: Any) -> SubmissionRules:
    keys = ("frame_rates", "samples", "require", "max_file_mb")
    table = reader.table(data, "submissions", keys)
    rates = reader.get(
        table, "frame_rates", "submissions.frame_rates", (list,), "an array of numbers", []
    )
    low, high = FRAME_RATE_RANGE
    for rate in rates:
        if isinstance(rate, bool) or not isinstance(rate, int | float) or not low <= rate <= high:
            raise reader.error(
                "submissions.frame_rates",
                f"expected frame rates in {low:g}..{high:g}, got {describe(rate)}",
            )
    require = reader.get(
        table, "require", "submissions.require", (list,), "an array of channel groups", []
    )
    for group in require:
        if group not in CHANNEL_GROUPS:
            raise reader.error(
                "submissions.require",
                f"expected groups of {', '.join(CHANNEL_GROUPS)}, got {describe(group)}",
            )
    pad = test.get("pad", False) if isinstance(test, Mapping) else False
    return SubmissionRules(
        frame_rates=tuple(float(r) for r in rates),
        samples=reader.integer(table, "samples", "submissions.samples", 5, 1, 20),
        require=tuple(dict.fromkeys(require)),
        max_file_mb=reader.integer(table, "max_file_mb", "submissions.max_file_mb", 20, 1, 1000),
        pad=bool(pad) if isinstance(pad, bool) else False,
    )


def _publish(reader: FieldReader, data: Any) -> PublishRules:
    keys = ("min_votes", "bootstrap", "confidence", "drift_alpha")
    table = reader.table(data, "publish", keys)
    confidence = reader.get(table, "confidence", "publish.confidence", (float,), "a number", 0.95)
    if not 0.5 <= confidence < 1.0:
        raise reader.error("publish.confidence", f"expected 0.5 to 0.999, got {confidence!r}")
    alpha = reader.get(table, "drift_alpha", "publish.drift_alpha", (float,), "a number", 0.05)
    if not 0.0 < alpha <= 0.5:
        raise reader.error("publish.drift_alpha", f"expected above 0, at most 0.5, got {alpha!r}")
    return PublishRules(
        min_votes=reader.integer(table, "min_votes", "publish.min_votes", 300, 0, 10**9),
        bootstrap=reader.integer(table, "bootstrap", "publish.bootstrap", 1000, 100, 100_000),
        confidence=float(confidence),
        drift_alpha=float(alpha),
    )


def _check_as_study(spec: SeasonSpec, source: str, check_files: bool) -> None:
    """``[render]`` and ``[test]`` read by the study file's reader, as the round study with the
    season's segments and anchors: an error names the season file's own field."""
    mapping = spec.study_mapping(
        title=spec.title,
        seed=spec.seed,
        conditions=[{"name": a, "model": a} for a in spec.rounds.anchors],
        clips=[
            {"name": s.name, "audio": str(s.audio), "ground_truth": str(s.ground_truth)}
            for s in spec.segments
        ],
    )
    try:
        parse_study(mapping, source=source, base_dir=spec.base_dir, check_files=check_files)
    except InputError as exc:
        raise InputError(exc.message, path=source, field=_season_field(exc.field)) from None


def _season_field(study_field: str | None) -> str | None:
    """The season file's name of a round study's field (``clips[1].audio`` is the season's
    ``segments[1].audio``, ``eyes`` is ``test.eyes``).

    >>> _season_field("clips[0].audio"), _season_field("catch.kind"), _season_field("render.size")
    ('segments[0].audio', 'test.catch.kind', 'render.size')
    """
    if study_field is None:
        return None
    if study_field.startswith("clips"):
        return "segments" + study_field[len("clips") :]
    if study_field.startswith("conditions"):
        return "rounds.anchors"
    if study_field.startswith("render"):
        return study_field
    if study_field == "target_participants":
        return "rounds.participants"
    return f"test.{study_field}"
