"""Every file a new study brings, checked before the study is created: each clip's speech
decodes (:func:`app.stimuli.audiofile.check_audio_file`: container, header, length, silence),
each ground truth and uploaded track parses (:func:`app.stimuli.io.load_track`). A bad file is
refused at upload with the one line the pipeline would have given, naming the file as the
experimenter uploaded it (never a server path), so it never becomes a failed job."""

from __future__ import annotations

from pathlib import Path

from app.errors import InputError
from app.stimuli.audiofile import check_audio_file
from app.stimuli.io import load_track
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
    for clip in spec.clips:
        try:
            summaries.append(check_audio_file(clip.audio))
        except InputError as exc:
            raise _named(exc, clip.audio, f"the speech of clip {clip.name}") from None
        if clip.ground_truth is not None:
            try:
                load_track(clip.ground_truth)
            except InputError as exc:
                raise _named(
                    exc, clip.ground_truth, f"the ground truth of clip {clip.name}"
                ) from None
    for condition in spec.conditions:
        for clip_name, path in condition.tracks.items():
            try:
                load_track(path)
            except InputError as exc:
                raise _named(exc, path, f"condition {condition.name}, clip {clip_name}") from None
    return summaries
