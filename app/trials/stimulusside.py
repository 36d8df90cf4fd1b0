"""The stimulus side of a study file: its clips, its conditions and how they are made and
rendered.

The clips are the speech the faces say (the thesis' segments S2 and S7; the 2012 paper's ten
audio clips, sec. 8.1.1), each with its captured ground truth where there is one; the
conditions are the models compared (thesis sec. 5.2: NO_PROSODY, RANDOM, SPEECH_DRIVEN,
GROUND_TRUTH), each a model of the stimulus engine with its settings or tracks uploaded for
every clip; the stimulus settings make what the study does not test the same in every
condition (``eyes``, ``posture``, ``lips``, ``brows``, ``meshes``, ``mesh_eyes``,
``normalize``, ``pad``: :mod:`app.stimuli.untested`) and fix the ``[render]`` table. The keys
are in ``docs/reference/studyfile.md``; :mod:`app.trials.studyfile` reads the rest of the file.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any, Final

from app.errors import InputError
from app.stimuli.eyes import DEFAULT_EYES, EYE_MODES
from app.stimuli.meshes.fairness import DEFAULT_MESH_EYES, MESH_EYES
from app.stimuli.posture import DEFAULT_POSTURE, POSTURES
from app.stimuli.shared import BROW_MODES, DEFAULT_BROWS, LIP_MODES
from app.trials.fields import FieldReader
from app.trials.meshtables import read_mesh_table
from app.trials.studyspec import MODELS, ClipSpec, ConditionSpec

AUDIO_SUFFIXES: Final = (".wav", ".flac", ".ogg", ".mp3", ".aiff", ".aif")
#: A track file: FAPs (.fap, .csv), a tracker's or tool's file (.csv, .json, .bvh), or a mesh or
#: FLAME sequence (.npy, .npz, .pkl: docs/reference/meshes.md).
TRACK_SUFFIXES: Final = (".fap", ".csv", ".json", ".bvh", ".npy", ".npz", ".pkl")

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
#: ``renderer.gl.ANTIALIAS_MODES``, repeated so that reading a study file imports no GL.
ANTIALIAS_MODES: Final = ("edges", "msaa", "none")
#: The smallest face ``renderer.RenderSettings`` renders (pixels, a multiple of 16).
MIN_FACE_SIZE: Final = 64
#: ``renderer.headmodel.LOOKS`` (the built-in head's looks), repeated for the same reason.
LOOKS: Final = ("textured", "plain")


class StimulusSideReader(FieldReader):
    """The clips, the conditions and the stimulus settings of a study file, on top of the
    typed field access of :class:`FieldReader`."""

    def stimulus_settings(
        self, top: Mapping[str, Any], clips: tuple[ClipSpec, ...]
    ) -> dict[str, Any]:
        """The stimulus settings as :class:`~app.trials.studyspec.StudySpec` fields: ``eyes``
        and ``normalize`` (the same for every condition), the ``[render]`` table, then
        ``posture``, ``lips``, ``pad``, ``brows``, ``meshes`` and ``mesh_eyes``."""
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
        return {
            "eyes": eyes,
            "normalize": normalize,
            "render": render,
            "posture": self.choice(top, "posture", "posture", POSTURES, DEFAULT_POSTURE),
            "lips": self.choice(top, "lips", "lips", LIP_MODES, None) if "lips" in top else None,
            "pad": bool(self.get(top, "pad", "pad", (bool,), "true or false", False)),
            "brows": self.choice(top, "brows", "brows", BROW_MODES, DEFAULT_BROWS),
            "meshes": read_mesh_table(self, top.get("meshes", {}), "meshes"),
            "mesh_eyes": self.choice(top, "mesh_eyes", "mesh_eyes", MESH_EYES, DEFAULT_MESH_EYES),
        }

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
