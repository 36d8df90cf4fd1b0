"""Turning a validated study (``app.trials.studyfile.StudySpec``) into rows and media files,
and the study's life cycle (draft -> ready -> open <-> paused -> closed, closed -> open again),
its copies and its deletion."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import TYPE_CHECKING, Any

import sqlalchemy as sa
from flask import current_app
from werkzeug.utils import secure_filename

from app.analysis.quality import parse_rules
from app.errors import InputError
from app.trials import design
from app.trials.participation import ParticipationSpec
from app.trials.rating import DEFAULT_RATING_SCALE
from app.trials.schedule import foreign_clip
from app.trials.stimuli import shown_stimuli, variant_stimuli
from app.web.extensions import db
from app.web.infra import media
from app.web.infra.storage import media_dir
from app.web.models import (
    Clip,
    Condition,
    Job,
    Pair,
    Participant,
    Rating,
    Stimulus,
    Study,
    StudyList,
    StudyShare,
    Track,
    Trial,
    User,
    Vote,
)

if TYPE_CHECKING:
    from app.trials.studyfile import StudySpec

#: Allowed recruitment transitions: action -> (states it may start from, resulting state).
TRANSITIONS: dict[str, tuple[tuple[str, ...], str]] = {
    "open": (("ready", "paused"), "open"),
    "pause": (("open",), "paused"),
    "close": (("open", "paused", "ready"), "closed"),
    "reopen": (("closed",), "open"),
}
#: States in which the stimuli may still be generated and rendered (until the first vote).
EDITABLE_STATES = ("draft", "ready")


def design_pairs(study: Study) -> list[design.ConditionPair]:
    """The study's pairs (:class:`app.trials.design.ConditionPair`) in the stored order."""
    return [design.ConditionPair(p.first.name, p.second.name) for p in study.pairs]


def practice_pair(study: Study) -> design.ConditionPair | None:
    """The practice pair of the study file's ``practice``, if any."""
    practice = (study.settings or {}).get("practice")
    return design.ConditionPair(practice[0], practice[1]) if practice else None


def participation(study: Study) -> ParticipationSpec:
    """The study's participant-side settings
    (:class:`app.trials.participation.ParticipationSpec`)."""
    return ParticipationSpec.from_settings((study.settings or {}).get("participation"))


def rating_scale(study: Any) -> str:
    """The rating designs' scale (``app.trials.rating.RATING_SCALES``) of ``study``, a row or
    an ORM object with ``settings``."""
    return str((study.settings or {}).get("rating_scale", DEFAULT_RATING_SCALE))


def stimulus_combinations(study: Study) -> list[tuple[str, str, str, str, str]]:
    """Every (clip, left, right, instruction, foreign side) some participant may see: the
    displayed pairs (:func:`app.trials.stimuli.shown_stimuli`), then the attention-check and
    appropriateness variants (:func:`app.trials.stimuli.variant_stimuli`)."""
    clips, pairs = [c.name for c in study.clips], design_pairs(study)
    plain = shown_stimuli(
        clips=clips,
        pairs=pairs,
        design=study.design,
        catch_trials=study.catch_trials,
        catch_kind=study.catch_kind,
        practice_pair=practice_pair(study),
        practice_clip=(study.settings or {}).get("practice_clip"),
    )
    variants = variant_stimuli(
        clips=clips,
        pairs=pairs,
        design=study.design,
        catch_trials=study.catch_trials,
        catch_kind=study.catch_kind,
        mismatched=participation(study).mismatched,
    )
    return [(clip, p.left, p.right, "", "") for clip, p in plain] + [
        (clip, p.left, p.right, instruction, foreign) for clip, p, instruction, foreign in variants
    ]


def _stored_name(path: str | Path) -> str:
    """An uploaded file's name as stored: its own, made safe for any file system, with its
    extension in lower case (the importers go by it).

    >>> _stored_name("/tmp/x/Nod ARKit.CSV"), _stored_name("../..csv")
    ('Nod_ARKit.csv', 'track.csv')
    """
    path = Path(path)
    suffix = path.suffix.lower()
    stem = secure_filename(path.stem)
    return f"{stem or 'track'}{suffix}"


def _copy(study: Study, source: Path, rel: str) -> str:
    target = media_dir(study) / rel
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, target)
    media.publish(study, rel)
    return rel


def check_caps(spec: StudySpec, *, max_conditions: int, max_clips: int, max_trials: int) -> None:
    """Refuse, in one line naming the field, a study larger than the deployment allows: every
    condition and clip is rendered, and every participant's trials are stored at consent, so
    200 conditions (40,000 ordered pairs a participant) would tie up the server. Counted in
    that order, so a huge design is refused before its schedule is built."""
    if len(spec.conditions) > max_conditions:
        raise InputError(
            f"{len(spec.conditions)} conditions, at most {max_conditions} (MAX_CONDITIONS)",
            field="conditions",
        )
    if len(spec.clips) > max_clips:
        raise InputError(f"{len(spec.clips)} clips, at most {max_clips} (MAX_CLIPS)", field="clips")
    trials = len(spec.schedule(seed=spec.seed, list_index=0))
    if trials > max_trials:
        raise InputError(
            f"{trials} trials a participant, at most {max_trials} (MAX_TRIALS_PER_PARTICIPANT): "
            "fewer conditions or clips, or another design",
            field="design",
        )


def create_study(
    owner: User, spec: StudySpec, *, source_toml: str = "", render: dict[str, Any] | None = None
) -> Study:
    """Rows for ``spec`` (study, conditions, clips, pairs, lists, stimuli); media copied into
    the study's folder. ``render`` overrides the study file's ``[render]`` settings. The
    study file's ``exclude`` rules are checked here (:func:`app.analysis.quality.parse_rules`).
    Not committed: the caller's unit of work decides."""
    parse_rules(spec.exclude)  # a bad rule: one line naming the field, before any row exists
    config = current_app.config
    check_caps(
        spec,
        max_conditions=int(config["MAX_CONDITIONS"]),
        max_clips=int(config["MAX_CLIPS"]),
        max_trials=int(config["MAX_TRIALS_PER_PARTICIPANT"]),
    )
    study = Study(
        owner_id=owner.id,
        title=spec.title,
        question=spec.question,
        instructions=spec.instructions,
        consent=spec.consent,
        design=spec.design,
        reference=spec.reference,
        allow_undecided=spec.undecided_allowed,
        undecided_label=spec.undecided_label,
        replay=spec.replay.kind,
        max_plays=spec.replay.max_plays,
        catch_trials=spec.catch_trials,
        catch_kind=spec.catch_kind,
        target_participants=spec.target_participants,
        completion_code=spec.completion_code,
        redirect_url=spec.redirect_url or "",
        seed=spec.seed,
        source_toml=source_toml,
        status="draft",
        settings={
            "practice": [spec.practice.left, spec.practice.right] if spec.practice else None,
            "practice_clip": spec.practice_clip,
            "block_by_clip": spec.block_by_clip,
            "eyes": spec.eyes,
            "posture": spec.posture,
            "lips": spec.lips,
            "brows": spec.brows,
            # [meshes]: the stored copies of its files, set in _media_rows
            "mesh_eyes": spec.mesh_eyes,
            "pad": spec.pad,
            "normalize": spec.normalize,
            "rejoin": spec.rejoin,
            "render": {k: v for k, v in {**spec.render, **(render or {})}.items() if k != "face"},
            # [render] face: the stored avatar, set in _media_rows
            "exclude": spec.exclude or None,
            "participation": spec.participation.to_dict(),
            "auto_exclude": list(spec.auto_exclude),
            "questions": [q.to_dict() for q in spec.questions],
            "rating_scale": spec.rating_scale,
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
    """Clips and conditions, their audio and tracks copied into the study's folder (a mesh
    condition's with the files it is read with: :mod:`app.web.study.meshmedia`)."""
    from app.web.study.meshmedia import copy_mesh_files, copy_siblings

    mesh_files: list[str] = []
    for position, clip in enumerate(spec.clips):
        audio = _copy(study, clip.audio, f"clips/{clip.name}/audio{clip.audio.suffix.lower()}")
        truth = None
        if clip.ground_truth is not None:
            truth = _copy(
                study,
                clip.ground_truth,
                f"clips/{clip.name}/ground_truth{clip.ground_truth.suffix.lower()}",
            )
            mesh_files += copy_siblings(study, clip.ground_truth, truth, _copy)
        study.clips.append(
            Clip(name=clip.name, audio_path=audio, ground_truth_path=truth, position=position)
        )
    face = spec.render.get("face")
    if face is not None:
        # the avatar (and its sidecar, when one came with it) beside the study's media; the
        # render job reads it from there (app.web.jobs.rendering.render_settings)
        stored = _copy(study, Path(face), f"render/{_stored_name(face)}")
        sidecar = Path(face).with_name(Path(face).stem + ".avatar.json")
        if sidecar.is_file():
            _copy(study, sidecar, f"render/{Path(stored).stem}.avatar.json")
        study.settings = {**study.settings, "render": {**study.settings["render"], "face": stored}}
    for position, cond in enumerate(spec.conditions):
        # each under its own name, which the notes on it use (the researcher knows no other)
        uploads = {
            clip: _copy(study, Path(path), f"uploads/{cond.name}/{clip}/{_stored_name(path)}")
            for clip, path in cond.tracks.items()
        }
        for clip, path in cond.tracks.items():
            mesh_files += copy_siblings(study, Path(path), uploads[clip], _copy)
        params = dict(cond.settings)
        if cond.mesh:
            params["mesh"] = copy_mesh_files(study, cond.mesh, f"meshes/{cond.name}", _copy)
        study.conditions.append(
            Condition(
                name=cond.name,
                model=cond.model or "upload",
                params=params,
                uploads=uploads,
                position=position,
            )
        )
    meshes = copy_mesh_files(study, spec.meshes, "meshes", _copy) if spec.meshes else {}
    if meshes or mesh_files:
        study.settings = {**study.settings, "meshes": meshes, "mesh_files": mesh_files}
    db.session.flush()


def _design_rows(study: Study, spec: StudySpec) -> None:
    """Pairs, balancing lists and the stimuli to render."""
    by_name = {c.name: c for c in study.conditions}
    for position, pair in enumerate(spec.pairs()):
        study.pairs.append(
            Pair(first=by_name[pair.left], second=by_name[pair.right], position=position)
        )
    for index in range(spec.n_lists()):
        study.lists.append(StudyList(index=index))
    db.session.flush()
    clips = {c.name: c for c in study.clips}
    names = list(clips)
    for clip, left, right, instruction, foreign in stimulus_combinations(study):
        lender = clips[foreign_clip(names, clip)].id if foreign else None
        db.session.add(
            Stimulus(
                study_id=study.id,
                clip_id=clips[clip].id,
                left_id=by_name[left].id,
                right_id=by_name[right].id,
                instruction=instruction,
                foreign_side=foreign,
                foreign_clip_id=lender,
            )
        )
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


def has_votes(study: Study) -> bool:
    """Whether any participant (pilot included) has voted, or rated, in ``study``."""
    return any(
        db.session.scalar(
            sa.select(answer.id)
            .join(Participant, answer.participant_id == Participant.id)
            .where(Participant.study_id == study.id)
            .limit(1)
        )
        is not None
        for answer in (Vote, Rating)
    )


def stimuli_locked(study: Study) -> str | None:
    """Why the stimuli of ``study`` can no longer be generated or rendered, or None.

    Once recruitment has opened, or anyone has voted, what participants saw is the record:
    a changed study is a new study (:func:`duplicate_study`).
    """
    if study.status not in EDITABLE_STATES:
        return f"the study is {study.status}; duplicate the study to change them"
    if has_votes(study):
        return "participants have voted on them; duplicate the study to change them"
    return None


#: Study columns a copy does not take over: its identity, links, secrets, state and history.
_NOT_COPIED = {
    "id",
    "owner_id",
    "slug",
    "pilot_token",
    "pseudonym_key",
    "status",
    "created_at",
    "report_at",
    "title",
}


def duplicate_study(study: Study, owner: User, *, with_clips: bool) -> Study:
    """A new draft of ``study`` owned by ``owner``: the same design, clips and conditions, new
    links and secrets, no participants. ``with_clips`` also copies the generated tracks and the
    rendered videos (the copy is then ready to open); without, they are generated again.
    Not committed."""
    copy = Study(
        owner_id=owner.id,
        title=f"{study.title} (copy)"[:200],
        status="draft",
        **{
            c.key: getattr(study, c.key)
            for c in Study.__table__.columns
            if c.key not in _NOT_COPIED
        },
    )
    db.session.add(copy)
    db.session.flush()
    source, target = media_dir(study), media_dir(copy)
    # meshes: the [meshes] files of a study of mesh conditions (app.web.study.meshmedia)
    kept = ("clips", "uploads", "render", "meshes") + (("tracks", "videos") if with_clips else ())
    for folder in kept:
        if (source / folder).is_dir():
            shutil.copytree(source / folder, target / folder, dirs_exist_ok=True)
            media.publish_folder(copy, folder)
    conditions = {
        c.id: Condition(
            name=c.name,
            model=c.model,
            params=dict(c.params),
            uploads=dict(c.uploads),
            position=c.position,
        )
        for c in study.conditions
    }
    clips = {
        c.id: Clip(
            name=c.name,
            audio_path=c.audio_path,
            ground_truth_path=c.ground_truth_path,
            position=c.position,
        )
        for c in study.clips
    }
    copy.conditions.extend(conditions.values())
    copy.clips.extend(clips.values())
    copy.pairs.extend(
        Pair(first=conditions[p.first_id], second=conditions[p.second_id], position=p.position)
        for p in study.pairs
    )
    copy.lists.extend(StudyList(index=sl.index) for sl in study.lists)
    db.session.flush()
    stimuli = db.session.scalars(sa.select(Stimulus).where(Stimulus.study_id == study.id))
    db.session.add_all(
        Stimulus(
            study_id=copy.id,
            clip_id=clips[s.clip_id].id,
            left_id=conditions[s.left_id].id,
            right_id=conditions[s.right_id].id,
            # An attention check's on-screen instruction, a mismatched pair's borrowed audio:
            # without them the variants collide on the stimulus key.
            instruction=s.instruction,
            foreign_side=s.foreign_side,
            foreign_clip_id=clips[s.foreign_clip_id].id if s.foreign_clip_id else None,
            video_path=s.video_path if with_clips else None,
            webm_path=s.webm_path if with_clips else None,
        )
        for s in stimuli
    )
    if with_clips:
        tracks = db.session.scalars(sa.select(Track).where(Track.clip_id.in_(list(clips))))
        db.session.add_all(
            Track(
                condition_id=conditions[t.condition_id].id, clip_id=clips[t.clip_id].id, path=t.path
            )
            for t in tracks
        )
        rendered = (
            db.session.scalar(
                sa.select(sa.func.count(Stimulus.id)).where(
                    Stimulus.study_id == study.id, Stimulus.video_path.is_(None)
                )
            )
            == 0
        )
        copy.status = "ready" if rendered else "draft"
    db.session.flush()
    return copy


def delete_study(study: Study) -> None:
    """Delete ``study`` with every row that belongs to it and its media folder (audio, tracks,
    videos, reports). Not committed; the files go first, so a failure leaves rows that still
    show the study rather than rows pointing at nothing."""
    media.forget(study)
    shutil.rmtree(media_dir(study), ignore_errors=True)
    participants = sa.select(Participant.id).where(Participant.study_id == study.id)
    conditions = sa.select(Condition.id).where(Condition.study_id == study.id)
    for statement in (
        sa.delete(Vote).where(Vote.participant_id.in_(participants)),
        sa.delete(Rating).where(Rating.participant_id.in_(participants)),
        sa.delete(Trial).where(Trial.participant_id.in_(participants)),
        sa.delete(Participant).where(Participant.study_id == study.id),
        sa.delete(Track).where(Track.condition_id.in_(conditions)),
        sa.delete(Stimulus).where(Stimulus.study_id == study.id),
        sa.delete(Pair).where(Pair.study_id == study.id),
        sa.delete(StudyList).where(StudyList.study_id == study.id),
        sa.delete(Clip).where(Clip.study_id == study.id),
        sa.delete(Condition).where(Condition.study_id == study.id),
        sa.delete(Job).where(Job.study_id == study.id),
        sa.delete(StudyShare).where(StudyShare.study_id == study.id),
    ):
        db.session.execute(statement.execution_options(synchronize_session=False))
    db.session.execute(
        sa.delete(Study).where(Study.id == study.id).execution_options(synchronize_session=False)
    )
    db.session.expire_all()
