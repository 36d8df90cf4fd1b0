"""Study files: a whole paired-comparison study described in one TOML file.

The file holds what the seeds' experiments fixed by hand: the conditions and the clips
(:mod:`app.trials.stimulusside`), the question (thesis sec. 5.2: "Which
animation do you consider to be more realistic motion-wise?"), the pair design
(:mod:`app.trials.design`), the undecided option (Le et al. 2012, sec. 8.1) and the replay policy
(:mod:`app.trials.rules`), plus what a remote study needs: consent text, a completion code, a
redirect URL, a target number of participants and the seed every schedule derives from.

Every key is documented in ``docs/reference/studyfile.md``; ``app/data/examples/study.toml`` is a
complete example.
Every mistake is one :class:`~app.errors.InputError` line naming the file and the field, e.g.
``study.toml: design: expected one of all_ordered, reference, unordered_counterbalanced,
adaptive, rating, parallel, got 'foo'``. Relative paths are resolved against the directory of
the study file.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, Final

from app.errors import InputError
from app.trials.adaptive import MIN_CONDITIONS
from app.trials.catch import CATCH_KINDS
from app.trials.design import DESIGNS, RATING_DESIGNS, REFERENCE_DESIGNS, ConditionPair
from app.trials.fields import MISSING, describe
from app.trials.participation import PARTICIPATION_KEYS, read_participation
from app.trials.questions import ExperimenterSideReader
from app.trials.rating import DEFAULT_RATING_SCALE, RATING_SCALES
from app.trials.recruiting import read_recruiting
from app.trials.rules import DEFAULT_UNDECIDED_LABEL, REPLAY_KINDS, ReplayPolicy
from app.trials.stimulusside import StimulusSideReader
from app.trials.studyspec import MODELS, ClipSpec, ConditionSpec, StudySpec

__all__ = [
    "StudySpec",
    "ConditionSpec",
    "ClipSpec",
    "load_study_file",
    "loads_study",
    "parse_study",
    "MODELS",
]


def load_study_file(
    path: str | Path, *, check_files: bool = True, confine: bool = False
) -> StudySpec:
    """Read and validate a TOML study file; paths inside resolve against its directory.

    ``check_files=False`` skips checking that audio and track files exist (for a file read
    without its media); ``confine=True`` refuses absolute paths and paths leaving the file's
    directory (use it for uploaded study files). Raises :class:`~app.errors.InputError` with
    one line naming the file and the field for every problem, including TOML syntax errors
    (with their line).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError("no such study file", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read study file: {exc}", path=path) from None
    return loads_study(
        text, source=str(path), base_dir=path.parent, check_files=check_files, confine=confine
    )


def loads_study(
    text: str,
    *,
    source: str = "study.toml",
    base_dir: str | Path = ".",
    check_files: bool = True,
    confine: bool = False,
    by_name: bool = False,
) -> StudySpec:
    """Parse and validate study-file text; ``source`` names it in errors (see
    :func:`load_study_file` for the options; ``by_name=True`` reads an uploaded study file,
    whose paths name files uploaded beside it: see :class:`~app.trials.fields.FieldReader`)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        found = re.search(r"at line (\d+)", str(exc))
        message = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise InputError(
            f"invalid TOML: {message}", path=source, line=int(found.group(1)) if found else None
        ) from None
    except RecursionError:  # tomllib recurses once per level of nested arrays and tables
        raise InputError("invalid TOML: arrays or tables nested too deeply", path=source) from None
    return parse_study(
        data,
        source=source,
        base_dir=base_dir,
        check_files=check_files,
        confine=confine,
        by_name=by_name,
    )


def parse_study(
    data: Mapping[str, Any],
    *,
    source: str = "study.toml",
    base_dir: str | Path = ".",
    check_files: bool = True,
    confine: bool = False,
    by_name: bool = False,
) -> StudySpec:
    """Validate an already-parsed study (a TOML document or a web form's mapping)."""
    reader = _StudyReader(
        source, Path(base_dir), check_files=check_files, confine=confine, by_name=by_name
    )
    return reader.study(data)


#: What a participant counted as dropped (idle past the deployment's DROPPED_AFTER_MINUTES)
#: meets on coming back: ``resume`` takes their list slot back, ``refuse`` ends their session.
REJOIN_POLICIES: Final = ("resume", "refuse")
_TOP_KEYS: Final = (
    "title",
    "question",
    "instructions",
    "consent",
    "design",
    "reference",
    "seed",
    "target_participants",
    "completion_code",
    "redirect_url",
    "block_by_clip",
    "eyes",
    "posture",
    "lips",
    "brows",
    "pad",
    "normalize",
    "meshes",
    "mesh_eyes",
    "rejoin",
    "render",
    "exclude",
    "practice",
    "practice_clip",
    "undecided",
    "replay",
    "catch",
    "rating",
    "conditions",
    "clips",
    *PARTICIPATION_KEYS,
    # -- the experimenter's side (docs/reference/studyfile.md, "Participants and questionnaires") --
    "auto_exclude",
    "demographics",
    "questions",
    # -- recruiting on Prolific (docs/reference/studyfile.md, "[prolific]") --
    "prolific",
)


class _StudyReader(StimulusSideReader, ExperimenterSideReader):
    """The study-file schema on top of the typed field access of :class:`FieldReader`: the
    stimulus side (:class:`StimulusSideReader`), the experimenter's side
    (:class:`ExperimenterSideReader`) and what lies between."""

    def study(self, data: Mapping[str, Any]) -> StudySpec:
        top = self.table(data, "", _TOP_KEYS)
        # read in the order of docs/reference/studyfile.md, so errors come top-down as a user fixes
        # them
        fields = self.front_matter(top)
        design = fields["design"]
        fields |= self.answering(top, design)
        clips = self.clips(top)
        conditions = self.conditions(top, clips)
        fields |= self.stimulus_settings(top, clips)
        fields["exclude"] = self.text(top, "exclude", "exclude", "")
        names = [c.name for c in conditions]
        self.check_design(design, fields["reference"], names)
        practice, practice_clip = self.practice(top, names, [c.name for c in clips], design)
        rejoin = self.choice(top, "rejoin", "rejoin", REJOIN_POLICIES, "resume")
        participation = read_participation(self, top, n_clips=len(clips))
        if design in RATING_DESIGNS and participation.mismatched:
            raise self.error("mismatched", f"only applies to the pair designs, not {design!r}")
        auto_exclude, questions = self.experimenter_side(top)
        recruiting = read_recruiting(self, top["prolific"]) if "prolific" in top else None
        spec = StudySpec(
            conditions=conditions,
            clips=clips,
            practice=practice,
            practice_clip=practice_clip,
            rejoin=rejoin,
            participation=participation,
            auto_exclude=auto_exclude,
            questions=questions,
            prolific=recruiting,
            **fields,
        )
        main = len(replace(spec, catch_trials=0, practice=None).schedule(seed=0, list_index=0))
        if spec.catch_trials > main:
            raise self.error(
                "catch.trials",
                f"{spec.catch_trials} catch trials do not fit among the "
                f"{main} trials of a participant (at most one each)",
            )
        return spec

    def front_matter(self, top: Mapping[str, Any]) -> dict[str, Any]:
        """What the file opens with, as :class:`StudySpec` fields: the title and question, the
        instructions and consent, the design and its reference, the seed, the target number of
        participants, the completion code and redirect URL, and ``block_by_clip``."""
        fields = {
            "title": self.text(top, "title", "title", nonempty=True),
            "question": self.text(top, "question", "question", nonempty=True),
            "instructions": self.text(top, "instructions", "instructions", ""),
            "consent": self.text(top, "consent", "consent", ""),
            "design": self.choice(top, "design", "design", DESIGNS, "all_ordered"),
            "reference": self.text(top, "reference", "reference", None),
            "seed": self.integer(top, "seed", "seed", 0, 0),
            "target_participants": self.integer(
                top, "target_participants", "target_participants", 20, 1
            ),
            "completion_code": self.text(top, "completion_code", "completion_code", ""),
            "redirect_url": self.text(top, "redirect_url", "redirect_url", None),
        }
        redirect = fields["redirect_url"]
        if redirect is not None and not re.fullmatch(r"https?://[^\s/]+[^\s]*", redirect):
            raise self.error(
                "redirect_url", f"expected an http:// or https:// URL, got {redirect!r}"
            )
        fields["block_by_clip"] = bool(
            self.get(top, "block_by_clip", "block_by_clip", (bool,), "true or false", True)
        )
        return fields

    def answering(self, top: Mapping[str, Any], design: str) -> dict[str, Any]:
        """How participants answer, as :class:`StudySpec` fields: the undecided option, the
        replay policy, the catch trials and the rating scale, checked against the design
        (``parallel``: ITU-R BS.1534-3's unlimited plays and hidden reference, no catch
        trials; ``rating``: instructed checks only)."""
        undecided = self.table(top.get("undecided", {}), "undecided", ("allowed", "label"))
        allowed = self.get(
            undecided, "allowed", "undecided.allowed", (bool,), "true or false", True
        )
        label = self.text(
            undecided, "label", "undecided.label", DEFAULT_UNDECIDED_LABEL, nonempty=True
        )
        replay = self.replay(top)
        catch = self.table(top.get("catch", {}), "catch", ("trials", "kind"))
        catch_trials = self.integer(catch, "trials", "catch.trials", 0, 0)
        rating = design in RATING_DESIGNS
        catch_kind = self.choice(
            catch, "kind", "catch.kind", CATCH_KINDS, "instructed" if rating else "identical"
        )
        if design == "parallel" and catch_trials:
            raise self.error(
                "catch.trials",
                "design = 'parallel' takes no catch trials: its hidden reference is the check "
                "(post-screening, ITU-R BS.1534-3 sec. 4.1.2)",
            )
        if design == "parallel" and replay.kind != "unlimited":
            raise self.error(
                "replay.policy",
                "design = 'parallel' plays its items as often as wanted (ITU-R BS.1534-3): "
                f"expected 'unlimited', got {replay.kind!r}",
            )
        if design == "rating" and catch_kind != "instructed":
            raise self.error(
                "catch.kind",
                f"design = {design!r} takes only 'instructed' checks (rate the clip Bad), "
                f"not {catch_kind!r}",
            )
        rating_scale = self.rating_scale(top, design)
        if catch_trials and catch_kind == "identical" and not allowed:
            raise self.error(
                "catch.kind",
                "'identical' catch trials expect the answer "
                "'undecided', which undecided.allowed = false forbids",
            )
        return {
            "undecided_allowed": bool(allowed),
            "undecided_label": str(label),
            "replay": replay,
            "catch_trials": catch_trials,
            "catch_kind": catch_kind,
            "rating_scale": rating_scale,
        }

    def check_design(self, design: str, reference: str | None, names: list[str]) -> None:
        """The design's demands on the conditions: a reference among them for the designs
        that have one (and none for the others), enough of them for ``adaptive``."""
        if design in REFERENCE_DESIGNS:
            if reference is None:
                raise self.error("reference", f"missing (required by design = {design!r})")
            if reference not in names:
                raise self.error(
                    "reference",
                    f"expected one of the conditions {', '.join(names)}, got {reference!r}",
                )
        elif reference is not None:
            raise self.error(
                "reference", f"only applies to designs 'reference' and 'parallel', not {design!r}"
            )
        if design == "adaptive" and len(names) < MIN_CONDITIONS:
            raise self.error(
                "design",
                f"'adaptive' needs at least {MIN_CONDITIONS} conditions, the study has "
                f"{len(names)}",
            )

    def rating_scale(self, top: Mapping[str, Any], design: str) -> str:
        """The ``[rating]`` table's ``scale``, for the rating designs only (``parallel``: the
        slider, always)."""
        table = self.table(top.get("rating", {}), "rating", ("scale",))
        if table and design not in RATING_DESIGNS:
            raise self.error(
                "rating", f"only applies to designs 'rating' and 'parallel', not {design!r}"
            )
        default = "slider" if design == "parallel" else DEFAULT_RATING_SCALE
        scale = str(self.choice(table, "scale", "rating.scale", RATING_SCALES, default))
        if design == "parallel" and scale != "slider":
            raise self.error(
                "rating.scale",
                f"design = 'parallel' rates on sliders: expected 'slider', got {scale!r}",
            )
        return scale

    def replay(self, top: Mapping[str, Any]) -> ReplayPolicy:
        replay = self.table(top.get("replay", {}), "replay", ("policy", "max_plays"))
        policy = self.choice(replay, "policy", "replay.policy", REPLAY_KINDS, "unlimited")
        if policy == "max_plays":
            max_plays: int | None = self.integer(
                replay, "max_plays", "replay.max_plays", MISSING, 1
            )
        else:
            if "max_plays" in replay:
                raise self.error(
                    "replay.max_plays", f"only applies to policy = 'max_plays', not {policy!r}"
                )
            max_plays = None
        return ReplayPolicy(policy, max_plays)

    def practice(
        self, top: Mapping[str, Any], conditions: list[str], clips: list[str], design: str
    ) -> tuple[ConditionPair | None, str | None]:
        if design in RATING_DESIGNS:
            if top.get("practice", False) is not False or "practice_clip" in top:
                raise self.error("practice", f"design = {design!r} has no practice pair")
            return None, None
        value = top.get("practice", [conditions[0], conditions[-1]])
        if value is False:
            pair = None
        elif (
            not isinstance(value, list)
            or len(value) != 2
            or not all(isinstance(v, str) for v in value)
        ):
            raise self.error(
                "practice", f"expected two condition names or false, got {describe(value)}"
            )
        else:
            for v in value:
                if v not in conditions:
                    raise self.error(
                        "practice", f"expected condition names ({', '.join(conditions)}), got {v!r}"
                    )
            pair = ConditionPair(value[0], value[1])
        clip = self.text(top, "practice_clip", "practice_clip", None)
        if clip is not None and clip not in clips:
            raise self.error(
                "practice_clip", f"expected one of the clips {', '.join(clips)}, got {clip!r}"
            )
        return pair, clip
