"""Every file a new study brings, checked before the study is created: each clip's speech
decodes (:func:`app.stimuli.speechaudio.check_audio_file`: container, header, length, silence),
each ground truth and uploaded track parses (:func:`app.stimuli.io.load_track`) and is as
long as its clip's speech (:func:`app.stimuli.lengths.length_note`), and the avatar of
``[render] face`` loads (``renderer.api.load_face``). A bad file is
refused at upload with the one line the pipeline would have given, naming the file as the
experimenter uploaded it (never a server path), so it never becomes a failed job."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from app.errors import InputError
from app.stimuli.io import load_track
from app.stimuli.lengths import length_note
from app.stimuli.speechaudio import read_speech_audio
from app.trials.studyspec import StudySpec


def _named(exc: InputError, path: Path, what: str) -> InputError:
    """``exc`` with the file named by its own name, not the folder it was staged in."""
    line = f" (line {exc.line})" if exc.line is not None else ""
    field = f"{exc.field}: " if exc.field else ""
    return InputError(f"{what}{line}: {field}{exc.message}", path=path.name)


def check_study_inputs(spec: StudySpec) -> list[str]:
    """Decode or parse every clip's audio and ground truth and every uploaded track of
    ``spec``; the audio files' summary lines. Raises :class:`InputError` naming the file."""
    summaries = []
    seconds: dict[str, float] = {}
    offset = next(
        (
            float(c.settings.get("offset", 0.0))
            for c in spec.conditions
            if c.model == "ground_truth"
        ),
        0.0,
    )
    for clip in spec.clips:
        try:
            decoded = read_speech_audio(clip.audio)
        except InputError as exc:
            raise _named(exc, clip.audio, f"the speech of clip {clip.name}") from None
        summaries.append(decoded.summary)
        seconds[clip.name] = len(decoded.samples) / decoded.sample_rate
        if clip.ground_truth is not None:
            what = f"the ground truth of clip {clip.name}"
            try:
                _check_track(clip.ground_truth, seconds[clip.name], spec.pad, offset, spec.meshes)
            except InputError as exc:
                raise _named(exc, clip.ground_truth, what) from None
    face = spec.render.get("face")
    if face is not None:
        try:
            _check_face(Path(face))
        except InputError as exc:
            raise _named(exc, Path(face), "the face of [render]") from None
    for condition in spec.conditions:
        for clip_name, path in condition.tracks.items():
            try:
                mesh = {**spec.meshes, **condition.mesh}
                _check_track(path, seconds[clip_name], spec.pad, mesh=mesh)
            except InputError as exc:
                raise _named(exc, path, f"condition {condition.name}, clip {clip_name}") from None
    return summaries


def _check_track(
    path: Path,
    seconds: float,
    pad: bool,
    offset: float = 0.0,
    mesh: Mapping[str, Any] | None = None,
) -> None:
    """A track file parses (a mesh or FLAME sequence with the study's ``mesh`` options) and,
    unless ``pad``, is as long as ``seconds`` of speech."""
    track = load_track(path, mesh=mesh)
    length_note(track, round(seconds * track.fps), track.fps, what="track", offset=offset, pad=pad)


def _check_face(path: Path) -> None:
    """The study's avatar or face file reads as the render job will read it (its sidecar
    ``<stem>.avatar.json`` beside it, when one was uploaded too)."""
    from renderer.api import RenderSettings, load_face  # reads files only: no GL is made

    load_face(RenderSettings(face=str(path)))
