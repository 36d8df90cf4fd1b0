"""Turning a validated study (``app.trials.studyfile.StudySpec``) into rows and media files,
and the study's life cycle (draft -> ready -> open <-> paused -> closed)."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import TYPE_CHECKING, Any

from app import design
from app.analysis.quality import parse_rules
from app.extensions import db
from app.models import Clip, Condition, Pair, Stimulus, Study, StudyList, User
from app.storage import media_dir
from app.trials.schedule import foreign_clip

if TYPE_CHECKING:
    from app.trials.studyfile import StudySpec

#: Allowed recruitment transitions: action -> (states it may start from, resulting state).
TRANSITIONS: dict[str, tuple[tuple[str, ...], str]] = {
    "open": (("ready", "paused"), "open"),
    "pause": (("open",), "paused"),
    "close": (("open", "paused", "ready"), "closed"),
}


def _copy(study: Study, source: Path, rel: str) -> str:
    target = media_dir(study) / rel
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, target)
    return rel


def create_study(owner: User, spec: StudySpec, *, source_toml: str = "",
                 render: dict[str, Any] | None = None) -> Study:
    """Rows for ``spec`` (study, conditions, clips, pairs, lists, stimuli); media copied into
    the study's folder. ``render`` overrides the study file's ``[render]`` settings. The
    study file's ``exclude`` rules are checked here (:func:`app.analysis.quality.parse_rules`).
    Not committed: the caller's unit of work decides."""
    parse_rules(spec.exclude)  # a bad rule: one line naming the field, before any row exists
    study = Study(
        owner_id=owner.id, title=spec.title, question=spec.question,
        instructions=spec.instructions, consent=spec.consent, design=spec.design,
        reference=spec.reference, allow_undecided=spec.undecided_allowed,
        undecided_label=spec.undecided_label, replay=spec.replay.kind,
        max_plays=spec.replay.max_plays, catch_trials=spec.catch_trials,
        catch_kind=spec.catch_kind, target_participants=spec.target_participants,
        completion_code=spec.completion_code, redirect_url=spec.redirect_url or "",
        seed=spec.seed, source_toml=source_toml, status="draft",
        settings={
            "practice": [spec.practice.left, spec.practice.right] if spec.practice else None,
            "practice_clip": spec.practice_clip,
            "block_by_clip": spec.block_by_clip,
            "eyes": spec.eyes,
            "normalize": spec.normalize,
            "rejoin": spec.rejoin,
            "render": {**spec.render, **(render or {})},
            "exclude": spec.exclude or None,
            "participation": spec.participation.to_dict(),
        },
    )
    db.session.add(study)
    db.session.flush()
    try:
        _media_rows(study, spec)
        _design_rows(study, spec)
    except BaseException:
        # Nothing half-written stays behind (a full disk, a value no column holds): the
        # caller rolls the rows back, the files go here.
        shutil.rmtree(media_dir(study), ignore_errors=True)
        raise
    return study


def _media_rows(study: Study, spec: StudySpec) -> None:
    """Clips and conditions, their audio and tracks copied into the study's folder."""
    for position, clip in enumerate(spec.clips):
        audio = _copy(study, clip.audio, f"clips/{clip.name}/audio{clip.audio.suffix.lower()}")
        truth = None
        if clip.ground_truth is not None:
            truth = _copy(study, clip.ground_truth,
                          f"clips/{clip.name}/ground_truth{clip.ground_truth.suffix.lower()}")
        study.clips.append(Clip(name=clip.name, audio_path=audio, ground_truth_path=truth,
                                position=position))
    for position, cond in enumerate(spec.conditions):
        uploads = {clip: _copy(study, Path(path), f"uploads/{cond.name}/{clip}"
                               f"{Path(path).suffix.lower()}")
                   for clip, path in cond.tracks.items()}
        study.conditions.append(Condition(name=cond.name, model=cond.model or "upload",
                                          params=dict(cond.settings), uploads=uploads,
                                          position=position))
    db.session.flush()


def _design_rows(study: Study, spec: StudySpec) -> None:
    """Pairs, balancing lists and the stimuli to render."""
    by_name = {c.name: c for c in study.conditions}
    for position, pair in enumerate(spec.pairs()):
        study.pairs.append(Pair(first=by_name[pair.left], second=by_name[pair.right],
                                position=position))
    for index in range(spec.n_lists()):
        study.lists.append(StudyList(index=index))
    db.session.flush()
    clips = {c.name: c for c in study.clips}
    names = list(clips)
    for clip, left, right, instruction, foreign in design.stimulus_combinations(study):
        lender = clips[foreign_clip(names, clip)].id if foreign else None
        db.session.add(Stimulus(study_id=study.id, clip_id=clips[clip].id,
                                left_id=by_name[left].id, right_id=by_name[right].id,
                                instruction=instruction, foreign_side=foreign,
                                foreign_clip_id=lender))
    db.session.flush()


def change_status(study: Study, action: str) -> str:
    """Apply a recruitment action; returns the new state or raises ValueError."""
    if action not in TRANSITIONS:
        raise ValueError(f"unknown action {action!r}")
    sources, target = TRANSITIONS[action]
    if study.status not in sources:
        raise ValueError(f"cannot {action} a study that is {study.status}")
    study.status = target
    return target
