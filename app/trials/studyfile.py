"""Study files: a whole paired-comparison study described in one TOML file.

The file holds what the seeds' experiments fixed by hand: the conditions (thesis sec. 5.2: the
four models NO_PROSODY, RANDOM, SPEECH_DRIVEN, GROUND_TRUTH), the clips (the thesis' segments S2
and S7; the 2012 paper's ten audio clips, sec. 8.1.1), the question (thesis sec. 5.2: "Which
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

import inspect
import re
import tomllib
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, Final

from app.errors import InputError
from app.stimuli.eyes import DEFAULT_EYES, EYE_MODES
from app.stimuli.meshes.fairness import DEFAULT_MESH_EYES, MESH_EYES
from app.stimuli.posture import DEFAULT_POSTURE, POSTURES
from app.stimuli.shared import BROW_MODES, DEFAULT_BROWS, LIP_MODES
from app.trials.adaptive import MIN_CONDITIONS
from app.trials.catch import CATCH_KINDS
from app.trials.design import DESIGNS, RATING_DESIGNS, REFERENCE_DESIGNS, ConditionPair
from app.trials.fields import MISSING, describe
from app.trials.meshtables import read_mesh_table
from app.trials.participation import PARTICIPATION_KEYS, read_participation
from app.trials.questions import ExperimenterSideReader
from app.trials.rating import DEFAULT_RATING_SCALE, RATING_SCALES
from app.trials.recruiting import read_recruiting
from app.trials.rules import DEFAULT_UNDECIDED_LABEL, REPLAY_KINDS, ReplayPolicy
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

AUDIO_SUFFIXES: Final = (".wav", ".flac", ".ogg", ".mp3", ".aiff", ".aif")
#: A track file: FAPs (.fap, .csv), a tracker's or tool's file (.csv, .json, .bvh), or a mesh or
#: FLAME sequence (.npy, .npz, .pkl: docs/reference/meshes.md).
TRACK_SUFFIXES: Final = (".fap", ".csv", ".json", ".bvh", ".npy", ".npz", ".pkl")


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


#: ``[render]`` keys a study file may set (``renderer.RenderSettings`` fields, which the render
#: job validates in full) and their types; the web layer never imports the renderer.
RENDER_KEYS: Final[dict[str, tuple[tuple[type, ...], str]]] = {
    "size": ((int,), "an integer (pixels per face, a multiple of 16)"),
    "mosaic_block": ((int,), "an integer (pixels; 0 = no mosaic)"),
    "mosaic_margin": ((int, float), "a number"),
    "antialias": ((str,), "a string"),
    "samples": ((int,), "an integer"),
    "fps": ((int, float), "a number"),
    "crf": ((int,), "an integer"),
    "preset": ((str,), "a string"),
    "look": ((str,), "a string"),
}
#: Files ``[render] face`` may name: a glTF 2.0 / VRM avatar or a face JSON file
#: (``renderer.avatar.AVATAR_SUFFIXES`` and the face format; docs/reference/renderer.md).
FACE_SUFFIXES: Final = (".glb", ".gltf", ".vrm", ".json")
#: What a participant counted as dropped (idle past the deployment's DROPPED_AFTER_MINUTES)
#: meets on coming back: ``resume`` takes their list slot back, ``refuse`` ends their session.
REJOIN_POLICIES: Final = ("resume", "refuse")
#: ``renderer.gl.ANTIALIAS_MODES``, repeated so that reading a study file imports no GL.
ANTIALIAS_MODES: Final = ("edges", "msaa", "none")
#: The smallest face ``renderer.RenderSettings`` renders (pixels, a multiple of 16).
MIN_FACE_SIZE: Final = 64
#: ``renderer.headmodel.LOOKS`` (the built-in head's looks), repeated for the same reason.
LOOKS: Final = ("textured", "plain")

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


class _StudyReader(ExperimenterSideReader):
    """The study-file schema on top of the typed field access of :class:`FieldReader`."""

    def study(self, data: Mapping[str, Any]) -> StudySpec:
        top = self.table(data, "", _TOP_KEYS)
        # read in the order of docs/reference/studyfile.md, so errors come top-down as a user fixes
        # them
        title = self.text(top, "title", "title", nonempty=True)
        question = self.text(top, "question", "question", nonempty=True)
        instructions = self.text(top, "instructions", "instructions", "")
        consent = self.text(top, "consent", "consent", "")
        design = self.choice(top, "design", "design", DESIGNS, "all_ordered")
        reference = self.text(top, "reference", "reference", None)
        seed = self.integer(top, "seed", "seed", 0, 0)
        target = self.integer(top, "target_participants", "target_participants", 20, 1)
        completion_code = self.text(top, "completion_code", "completion_code", "")
        redirect = self.text(top, "redirect_url", "redirect_url", None)
        if redirect is not None and not re.fullmatch(r"https?://[^\s/]+[^\s]*", redirect):
            raise self.error(
                "redirect_url", f"expected an http:// or https:// URL, got {redirect!r}"
            )
        block_by_clip = self.get(
            top, "block_by_clip", "block_by_clip", (bool,), "true or false", True
        )
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
        clips = self.clips(top)
        conditions = self.conditions(top, clips)
        eyes, normalize, render = self.stimulus_settings(top, clips)
        posture = self.choice(top, "posture", "posture", POSTURES, DEFAULT_POSTURE)
        lips = self.choice(top, "lips", "lips", LIP_MODES, None) if "lips" in top else None
        pad = bool(self.get(top, "pad", "pad", (bool,), "true or false", False))
        brows = self.choice(top, "brows", "brows", BROW_MODES, DEFAULT_BROWS)
        meshes = read_mesh_table(self, top.get("meshes", {}), "meshes")
        mesh_eyes = self.choice(top, "mesh_eyes", "mesh_eyes", MESH_EYES, DEFAULT_MESH_EYES)
        exclude = self.text(top, "exclude", "exclude", "")
        names = [c.name for c in conditions]
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
        practice, practice_clip = self.practice(top, names, [c.name for c in clips], design)
        rejoin = self.choice(top, "rejoin", "rejoin", REJOIN_POLICIES, "resume")
        participation = read_participation(self, top, n_clips=len(clips))
        if rating and participation.mismatched:
            raise self.error("mismatched", f"only applies to the pair designs, not {design!r}")
        auto_exclude, questions = self.experimenter_side(top)
        recruiting = read_recruiting(self, top["prolific"]) if "prolific" in top else None
        spec = StudySpec(
            title=title,
            question=question,
            instructions=instructions,
            consent=consent,
            conditions=conditions,
            clips=clips,
            design=design,
            reference=reference,
            undecided_allowed=bool(allowed),
            undecided_label=str(label),
            replay=replay,
            catch_trials=catch_trials,
            catch_kind=catch_kind,
            target_participants=target,
            completion_code=completion_code,
            redirect_url=redirect,
            seed=seed,
            practice=practice,
            practice_clip=practice_clip,
            block_by_clip=bool(block_by_clip),
            eyes=eyes,
            posture=posture,
            lips=lips,
            brows=brows,
            meshes=meshes,
            mesh_eyes=mesh_eyes,
            pad=pad,
            normalize=normalize,
            render=render,
            exclude=exclude,
            rejoin=rejoin,
            participation=participation,
            rating_scale=rating_scale,
            auto_exclude=auto_exclude,
            questions=questions,
            prolific=recruiting,
        )
        main = len(replace(spec, catch_trials=0, practice=None).schedule(seed=0, list_index=0))
        if catch_trials > main:
            raise self.error(
                "catch.trials",
                f"{catch_trials} catch trials do not fit among the "
                f"{main} trials of a participant (at most one each)",
            )
        return spec

    def stimulus_settings(
        self, top: Mapping[str, Any], clips: tuple[ClipSpec, ...]
    ) -> tuple[str, bool, dict[str, Any]]:
        """``eyes`` and ``normalize`` (the same for every condition) and the ``[render]`` table."""
        eyes = self.choice(top, "eyes", "eyes", EYE_MODES, DEFAULT_EYES)
        normalize = bool(self.get(top, "normalize", "normalize", (bool,), "true or false", False))
        for key, wanted in (("eyes", eyes == "ground_truth"), ("normalize", normalize)):
            lacking = [c.name for c in clips if c.ground_truth is None]
            if wanted and lacking:
                raise self.error(
                    key, f"needs a ground_truth for every clip; missing for {', '.join(lacking)}"
                )
        table = self.table(top.get("render", {}), "render", (*RENDER_KEYS, "face"))
        render: dict[str, Any] = {}
        if "face" in table:
            render["face"] = self.file(table, "face", "render.face", FACE_SUFFIXES)
        for key, (types, expected) in RENDER_KEYS.items():
            if key in table:
                render[key] = self.get(table, key, f"render.{key}", types, expected)
        if "antialias" in render:
            self.choice(render, "antialias", "render.antialias", ANTIALIAS_MODES)
        if "look" in render:
            self.choice(render, "look", "render.look", LOOKS)
        size = render.get("size")
        if size is not None and (size < MIN_FACE_SIZE or size % 16):
            # renderer.RenderSettings' rule, checked here so a study is refused at upload and
            # not in its render job
            raise self.error(
                "render.size",
                f"expected a multiple of 16 of at least {MIN_FACE_SIZE} pixels, got {size}",
            )
        return eyes, normalize, render

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

    def clips(self, top: Mapping[str, Any]) -> tuple[ClipSpec, ...]:
        items = self.get(top, "clips", "clips", (list,), "an array of tables ([[clips]])")
        if not items:
            raise self.error("clips", "needs at least one clip")
        clips: list[ClipSpec] = []
        for index, item in enumerate(items):
            name = f"clips[{index}]"
            item = self.table(item, name, ("name", "audio", "ground_truth"))
            clip_name = self.identifier(item, "name", f"{name}.name")
            if clip_name in [c.name for c in clips]:
                raise self.error(f"{name}.name", f"repeats clip name {clip_name!r}")
            audio = self.file(item, "audio", f"{name}.audio", AUDIO_SUFFIXES)
            truth = self.file(item, "ground_truth", f"{name}.ground_truth", TRACK_SUFFIXES, None)
            clips.append(ClipSpec(clip_name, audio, truth))
        return tuple(clips)

    def conditions(
        self, top: Mapping[str, Any], clips: tuple[ClipSpec, ...]
    ) -> tuple[ConditionSpec, ...]:
        items = self.get(
            top, "conditions", "conditions", (list,), "an array of tables ([[conditions]])"
        )
        if len(items) < 2:
            raise self.error("conditions", f"needs at least two conditions, got {len(items)}")
        out: list[ConditionSpec] = []
        clip_names = [c.name for c in clips]
        for index, item in enumerate(items):
            name = f"conditions[{index}]"
            item = self.table(item, name, ("name", "model", "settings", "tracks", "mesh"))
            cond = self.identifier(item, "name", f"{name}.name")
            if cond in [c.name for c in out]:
                raise self.error(f"{name}.name", f"repeats condition name {cond!r}")
            if "mesh" in item and "tracks" not in item:
                raise self.error(f"{name}.mesh", "only applies to a condition of uploaded tracks")
            if "tracks" in item:
                for key in ("model", "settings"):
                    if key in item:
                        raise self.error(
                            f"{name}.{key}",
                            "a condition has either uploaded tracks or a model, not both",
                        )
                tracks = self.table(item["tracks"], f"{name}.tracks", tuple(clip_names))
                missing = [c for c in clip_names if c not in tracks]
                if missing:
                    raise self.error(f"{name}.tracks", f"no track for clip(s) {', '.join(missing)}")
                paths = {
                    c: self.file(tracks, c, f"{name}.tracks.{c}", TRACK_SUFFIXES)
                    for c in clip_names
                }
                mesh = read_mesh_table(self, item.get("mesh", {}), f"{name}.mesh")
                out.append(ConditionSpec(cond, None, {}, paths, mesh))
                continue
            if "model" not in item and cond not in MODELS:
                raise self.error(
                    f"{name}.model",
                    f"missing: give a model ({', '.join(MODELS)}) or uploaded tracks",
                )
            model = self.choice(item, "model", f"{name}.model", MODELS, cond)
            settings = self.get(item, "settings", f"{name}.settings", (dict,), "a table", {})
            problem = _settings_problem(model, settings)
            if problem:
                raise self.error(f"{name}.settings", problem)
            if model == "ground_truth":
                for number, clip in enumerate(clips):
                    if clip.ground_truth is None:
                        raise self.error(
                            f"clips[{number}].ground_truth",
                            f"missing (required by condition {cond!r}, model 'ground_truth')",
                        )
            out.append(ConditionSpec(cond, model, dict(settings), {}))
        return tuple(out)

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


def _settings_problem(model: str, settings: Mapping[str, Any]) -> str | None:
    """Why ``settings`` cannot be the keyword parameters of ``model``'s class, if it can be told.

    Asks the stimulus engine's registry (``condition_class``); when the registry or the model's
    module is not installed the settings are left for the generation step to check.
    """
    try:
        from app.stimuli.conditions import condition_class

        parameters = inspect.signature(condition_class(model)).parameters.values()
    except (ImportError, InputError, TypeError, ValueError):
        return None
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters):
        return None
    accepted = [
        p.name
        for p in parameters
        if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    ]
    unknown = [key for key in settings if key not in accepted]
    if unknown:
        takes = ", ".join(accepted) if accepted else "no settings"
        return f"model {model!r} takes {takes}; unknown: {', '.join(unknown)}"
    return None
