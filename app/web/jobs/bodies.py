"""The job bodies: what each kind of job does to its study (:data:`TASKS`), and :func:`run_job`,
which runs one on its row. Each runs inside an application context and reports progress on its
row; a runner (:mod:`app.web.jobs`) decides where.

The pure packages are imported inside the functions: the web process never loads the renderer's
GL stack, and a missing optional part fails the job with one clear message instead of breaking
the application.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import sqlalchemy as sa
from flask import current_app
from rq import Callback, Queue, get_current_job
from rq.job import Dependency
from sqlalchemy.exc import SQLAlchemyError

from app.trials.design import RATING_DESIGNS
from app.web.extensions import db, transaction
from app.web.infra import media
from app.web.infra.storage import media_dir
from app.web.jobs.queue import JOB_TIMEOUT, QUEUE, clip_job_id, finish_job_id
from app.web.jobs.rendering import render_inputs, render_stimulus, rendered, rendering_finished
from app.web.jobs.rows import beat_interval, failure_message
from app.web.models import Job, Study, Track, utcnow

log = logging.getLogger(__name__)

JOB_KINDS = ("generate", "render", "report")


def _progress(
    job_id: int,
    *,
    min_interval: float = 0.5,
    beat_every: float = 30.0,
    echo: Callable[[int, int], None] | None = None,
) -> Callable[[int, int], None]:
    """A ``progress(done, total)`` callback that writes the job row at most every
    ``min_interval`` seconds and passes each new value on to ``echo`` (e.g. a CLI progress
    bar). Called again with the same values (from inside a long step, such as every frame of
    one clip) it still refreshes the heartbeat every ``beat_every`` seconds, so a step longer
    than JOB_STALE_AFTER_SECONDS is never mistaken for a dead process."""
    state: dict[str, Any] = {"written_at": -math.inf, "written": None, "echoed": None}

    def report(done: int, total: int) -> None:
        values = (int(done), int(total))
        if echo is not None and values != state["echoed"]:
            state["echoed"] = values
            echo(*values)
        now = time.monotonic()
        wait = beat_every if values == state["written"] else min_interval
        if now - state["written_at"] < wait and done < total:
            return
        state["written_at"] = now
        try:
            with transaction() as session:
                session.execute(
                    sa.update(Job)
                    .where(Job.id == job_id)
                    .values(done=values[0], total=values[1], heartbeat_at=utcnow())
                )
        except SQLAlchemyError:
            # The database is briefly away (a restart): the work goes on, the next report
            # writes the row. Only an outage longer than the stale timeout fails the job.
            log.warning("job %s: progress not recorded (database unreachable)", job_id)
            return
        state["written"] = values

    return report


def generate_tracks(study: Study, progress: Callable[[int, int], None]) -> str:
    """Motion tracks of every condition on every clip (``app.stimuli.generate``): the models'
    and the uploaded ones alike, so that uploaded tracks share the eyes, posture and lower
    face of the clip as every condition does (:mod:`app.stimuli.shared`)."""
    from app.stimuli.eyes import DEFAULT_EYES
    from app.stimuli.generate import generate_conditions
    from app.stimuli.io import save_track
    from app.stimuli.posture import DEFAULT_POSTURE
    from app.stimuli.shared import DEFAULT_BROWS, lips_for
    from app.web.study.meshmedia import (
        fetch_mesh_options,
        fetch_siblings,
        publish_bundle,
    )

    root = media_dir(study)
    total = len(study.clips) * len(study.conditions)
    done = 0
    notes: list[str] = []
    progress(done, total)
    settings = study.settings
    lips = lips_for(settings.get("lips"), (settings.get("render") or {}).get("mosaic_block"))
    for clip in study.clips:
        conditions: dict[str, dict[str, Any]] = {}
        for condition in study.conditions:
            if condition.model != "upload":
                conditions[condition.name] = {"model": condition.model, **condition.params}
                continue
            source = condition.uploads.get(clip.name)
            if source is None:
                raise ValueError(
                    f"condition {condition.name}: no uploaded track for clip {clip.name}"
                )
            fetch_siblings(study, source)  # a mesh's template and pose beside it
            conditions[condition.name] = {
                "track": str(media.fetch(study, source)),
                # stored as uploads/<condition>/<clip>/<the file's own name>
                "label": Path(source).name,
            }
            if condition.params.get("mesh"):
                mesh = fetch_mesh_options(study, condition.params["mesh"])
                conditions[condition.name]["mesh"] = mesh
        if clip.ground_truth_path:
            fetch_siblings(study, clip.ground_truth_path)
        result = generate_conditions(
            media.fetch(study, clip.audio_path),
            conditions=conditions,
            ground_truth=(
                media.fetch(study, clip.ground_truth_path) if clip.ground_truth_path else None
            ),
            seed=study.seed,
            eyes=settings.get("eyes", DEFAULT_EYES),
            posture=settings.get("posture", DEFAULT_POSTURE),
            lips=lips,
            brows=settings.get("brows", DEFAULT_BROWS),
            pad=bool(settings.get("pad", False)),
            normalize=bool(settings.get("normalize", False)),
            meshes=fetch_mesh_options(study, settings.get("meshes")),
            mesh_eyes=settings.get("mesh_eyes", "match"),
        )
        notes += [f"clip {clip.name}: {n}" for n in result.summary["notes"] if _job_note(n)]
        for condition in study.conditions:
            rel = f"tracks/{clip.name}/{condition.name}.fap"
            (root / rel).parent.mkdir(parents=True, exist_ok=True)
            save_track(result.tracks[condition.name], root / rel)
            media.publish(study, rel)
            publish_bundle(study, rel, root)  # a mesh condition's vertices, beside its track
            _upsert_track(condition.id, clip.id, rel)
            done += 1
            progress(done, total)
    db.session.commit()
    if lips == "own" and len(study.conditions) > 1:
        notes.append("each condition keeps its own jaw and lip motion (no mouth mosaic)")
    return "; ".join([f"{done} tracks generated", *dict.fromkeys(notes)])


def _job_note(note: str) -> bool:
    """Whether a generation note belongs in the job's message: what happened to a file the
    experimenter gave (imported, padded or cut), not the models' own remarks."""
    return " imported from " in note or " s of motion for " in note


def _upsert_track(condition_id: int, clip_id: int, rel: str) -> None:
    track = db.session.scalar(
        sa.select(Track).where(Track.condition_id == condition_id, Track.clip_id == clip_id)
    )
    if track is None:
        db.session.add(Track(condition_id=condition_id, clip_id=clip_id, path=rel))
    else:
        track.path = rel


def render_clips(study: Study, progress: Callable[[int, int], None]) -> str:
    """Render every stimulus video of the study, one after the other in this process (an RQ
    worker splits the render into one job per clip instead: ``app.web.jobs.clips``)."""
    tracks, stimuli = render_inputs(study)
    # A retried job resumes: clips rendered before (their file in place) are kept.
    kept = sum(rendered(study, s) for s in stimuli)
    for i, stim in enumerate(stimuli):
        progress(i, len(stimuli))
        if rendered(study, stim):
            continue
        # every frame is a sign of life: a clip may take longer than the stale timeout
        render_stimulus(study, stim, tracks, lambda _frame, _frames, i=i: progress(i, len(stimuli)))
    progress(len(stimuli), len(stimuli))
    return rendering_finished(study, len(stimuli), kept)


def split_render(study: Study, job_id: int, progress: Callable[[int, int], None]) -> bool:
    """Queue one RQ job per clip of ``study`` still to render and the closing job, on the
    queue of the RQ job running now; False (nothing queued) when every clip is in place."""

    _, stimuli = render_inputs(study)
    todo = [s.id for s in stimuli if not rendered(study, s)]
    if not todo:
        return False
    progress(len(stimuli) - len(todo), len(stimuli))
    # Queued again until a worker starts its first clip: the clips may wait behind other
    # studies' longer than JOB_STALE_AFTER_SECONDS, and the sweeper asks RQ about a queued
    # row (the closing job, deferred while clips are left) instead of its heartbeat.
    with transaction() as session:
        session.execute(
            sa.update(Job)
            .where(Job.id == job_id)
            .values(
                status="queued", message=f"{len(todo)} clips queued, one job each, for any worker"
            )
        )
    queue = Queue(QUEUE, connection=get_current_job().connection)  # type: ignore[union-attr]
    failed = Callback("app.web.jobs.tasks.rq_failed")
    clips = queue.enqueue_many(
        [
            Queue.prepare_data(
                "app.web.jobs.clips.render_clip_standalone",
                (job_id, stimulus_id),
                job_id=clip_job_id(job_id, stimulus_id),
                timeout=JOB_TIMEOUT,
                on_failure=failed,
                result_ttl=JOB_TIMEOUT,
            )
            for stimulus_id in todo
        ]
    )
    # allow_failure: the closing job runs after a failed clip too, and says what is missing.
    queue.enqueue(
        "app.web.jobs.clips.finish_render_standalone",
        job_id,
        len(stimuli) - len(todo),
        job_id=finish_job_id(job_id),
        job_timeout=600,
        on_failure=failed,
        depends_on=Dependency(jobs=clips, allow_failure=True),
        result_ttl=JOB_TIMEOUT,
    )
    return True


def build_report(study: Study, progress: Callable[[int, int], None]) -> str:
    """The analysis report of the votes so far (``app.analysis``), as HTML."""
    from app.web.study.exports import write_report_files

    progress(0, 1)
    path = write_report_files(study)
    media.publish_folder(study, path.parent.name)
    study.report_at = utcnow()
    db.session.commit()
    progress(1, 1)
    if not path.with_suffix(".pdf").is_file():
        return NO_RATINGS_SUMMARY if study.design in RATING_DESIGNS else NO_VOTES_SUMMARY
    return f"report written: {path.name}"


#: A report job's summary when the study has no vote to analyse (the page says so, no PDF).
NO_VOTES_SUMMARY = "no votes to analyse yet: report page written (no PDF)"
#: The same for a rating study without a rating to analyse.
NO_RATINGS_SUMMARY = "no ratings to analyse yet: report page written (no PDF)"


def prepare_clips(study: Study, progress: Callable[[int, int], None]) -> str:
    """Generate the tracks, then render the clips, in one job: what a study made without an
    experimenter at the buttons needs (a leaderboard round or preview, ``app.web.board``), since
    two jobs on several RQ workers could render before the tracks exist."""
    generated = generate_tracks(study, lambda done, total: progress(done, 2 * total))
    rendered = render_clips(study, lambda done, total: progress(total + done, 2 * total))
    return f"{generated}; {rendered}"


TASKS: dict[str, Callable[[Study, Callable[[int, int], None]], str]] = {
    "generate": generate_tracks,
    "render": render_clips,
    "report": build_report,
    # not one of JOB_KINDS (the study page's buttons): started by the leaderboard
    "prepare": prepare_clips,
}


def run_job(job_id: int, *, echo: Callable[[int, int], None] | None = None) -> str:
    """Run job ``job_id``; its row ends ``done`` with a summary or ``failed`` with the error.
    Returns the final status."""
    job = db.session.get(Job, job_id)
    if job is None:
        log.warning("job %s vanished", job_id)
        return "failed"
    study_id, kind = job.study_id, job.kind
    # Only a queued row starts: one the sweeper gave up (and the experimenter may have retried)
    # stays failed instead of rendering beside its retry.
    started = db.session.execute(
        sa.update(Job)
        .where(Job.id == job_id, Job.status == "queued")
        .values(status="running", heartbeat_at=utcnow())
        .execution_options(synchronize_session=False)
    )
    db.session.commit()
    if started.rowcount != 1:
        log.warning("job %s is no longer queued; not started", job_id)
        return str(db.session.scalar(sa.select(Job.status).where(Job.id == job_id)))
    beat = beat_interval(current_app.config.get("JOB_STALE_AFTER_SECONDS", 900))
    try:
        study = db.session.get(Study, study_id)
        progress = _progress(job_id, beat_every=beat, echo=echo)
        if kind == "render" and _in_rq_worker():
            if split_render(study, job_id, progress):  # type: ignore[arg-type]
                return "running"  # its clip jobs end the row (app.web.jobs.clips)
        message = TASKS[kind](study, progress)  # type: ignore[arg-type]
        status = "done"
    except Exception as exc:  # noqa: BLE001 - every failure must reach the experimenter
        db.session.rollback()
        log.exception("job %s (%s) failed", job_id, kind)
        message = failure_message(exc)
        status = "failed"
    with transaction() as session:
        job = session.get(Job, job_id)
        job.status, job.message, job.finished_at = status, message, utcnow()  # type: ignore[union-attr]
        if status == "done":
            job.done = job.total = max(job.total, 1)  # type: ignore[union-attr]
    return status


def _in_rq_worker() -> bool:

    return get_current_job() is not None
