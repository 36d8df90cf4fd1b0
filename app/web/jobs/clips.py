"""A study's render split into one RQ job per clip, so N workers render N clips at once.

The render job's row is the parent. Run by an RQ worker, it queues
(:func:`app.web.jobs.bodies.split_render`) one job per clip still to render
(:func:`render_clip_standalone`, RQ id :func:`~app.web.jobs.queue.clip_job_id`) and one closing
job that depends on all of them (:func:`finish_render_standalone`, RQ id
:func:`~app.web.jobs.queue.finish_job_id`), then returns with its row ``queued`` again: while
the clips wait their turn the sweeper asks RQ about the closing job, not the heartbeat. The
first clip job to start sets the row ``running``; each adds one to the row's ``done`` (the study
page shows k of n clips, summed over the workers) and renews its heartbeat every frame; the
closing job ends the row ``done`` when every clip is in place, ``failed`` otherwise. The clip
jobs carry the parent's id as their first argument, so the lifecycle of :mod:`app.web.jobs`
applies to them unchanged: a failing clip (an exception, a timeout, a killed work horse) marks
the parent failed with its reason at once, the clips still queued behind it then skip, and a
worker that vanished leaves the row without heartbeat until the sweeper fails it. A retry
renders only the clips not yet in place.
"""

from __future__ import annotations

import logging
import socket
import time
from collections.abc import Callable
from typing import Any

import sqlalchemy as sa
from flask import current_app
from rq import get_current_job
from sqlalchemy.exc import SQLAlchemyError

from app.web.extensions import db, transaction
from app.web.jobs.rendering import render_inputs, render_stimulus, rendered, rendering_finished
from app.web.jobs.rows import beat_interval, failure_message, mark_failed
from app.web.models import Job, Stimulus, Study, utcnow
from app.web.standalone import app_context, offline_app

log = logging.getLogger(__name__)


def _worker_name() -> str:

    current = get_current_job()
    return (current.worker_name if current is not None else None) or socket.gethostname()


def _beat(job_id: int, every: float) -> Callable[[int, int], None]:
    """A per-frame callback renewing the parent row's heartbeat at most every ``every`` s."""
    last = [-float("inf")]

    def beat(_frame: int, _frames: int) -> None:
        if time.monotonic() - last[0] < every:
            return
        last[0] = time.monotonic()
        try:
            with transaction() as session:
                session.execute(
                    sa.update(Job)
                    .where(Job.id == job_id, Job.status == "running")
                    .values(heartbeat_at=utcnow())
                )
        except SQLAlchemyError:  # a database restart loses one beat, not the clip
            log.warning("job %s: heartbeat not recorded (database unreachable)", job_id)

    return beat


def render_clip(job_id: int, stimulus_id: int) -> dict[str, Any]:
    """Render one clip of render row ``job_id`` and count it on the row; a failure fails the
    row with the clip's name. Returns the stimulus, the worker and what happened."""

    worker = _worker_name()
    outcome = {"stimulus": stimulus_id, "worker": worker, "rendered": False}
    with transaction() as session:
        started = session.execute(
            sa.update(Job)
            .where(Job.id == job_id, Job.status.in_(("queued", "running")))
            .values(status="running", heartbeat_at=utcnow())
        ).rowcount
    stim = db.session.get(Stimulus, stimulus_id)
    if started != 1 or stim is None:
        # The render failed or was given up meanwhile: its retry renders this clip.
        status = db.session.scalar(sa.select(Job.status).where(Job.id == job_id))
        return {**outcome, "skipped": status}
    label = f"{stim.clip.name} {stim.left.name}/{stim.right.name}"
    try:
        study = db.session.get(Study, stim.study_id)
        if not rendered(study, stim):  # type: ignore[arg-type]
            tracks, _ = render_inputs(study)  # type: ignore[arg-type]
            every = beat_interval(current_app.config.get("JOB_STALE_AFTER_SECONDS", 900))
            render_stimulus(study, stim, tracks, _beat(job_id, every))  # type: ignore[arg-type]
            outcome["rendered"] = True
        with transaction() as session:
            session.execute(
                sa.update(Job)
                .where(Job.id == job_id, Job.status == "running")
                .values(
                    done=Job.done + 1,
                    heartbeat_at=utcnow(),
                    message=f"clip {label} rendered by {worker}",
                )
            )
    except Exception as exc:  # noqa: BLE001 - every failure must reach the experimenter
        db.session.rollback()
        log.exception("job %s: clip %s failed", job_id, label)
        mark_failed(job_id, f"clip {label}: {failure_message(exc)}; retry it")
        return {**outcome, "failed": failure_message(exc)}
    log.info("job %s: clip %s rendered by %s", job_id, label, worker)
    return outcome


def finish_render(job_id: int, kept: int) -> str:
    """End render row ``job_id`` once its clip jobs have ended: ``done`` when every clip of
    the study is in place, else ``failed`` naming how many are. Returns the row's status."""

    job = db.session.get(Job, job_id)
    if job is None or job.status not in ("queued", "running"):
        return job.status if job is not None else "failed"
    study = job.study
    _, stimuli = render_inputs(study)
    missing = sum(not rendered(study, s) for s in stimuli)
    if missing:
        mark_failed(
            job_id,
            f"{len(stimuli) - missing} of {len(stimuli)} clips rendered; "
            "retry it to render the rest",
        )
        return "failed"
    current = get_current_job()
    workers = (
        {(d.return_value() or {}).get("worker") for d in current.fetch_dependencies()}
        if current is not None
        else set()
    )
    message = rendering_finished(study, len(stimuli), kept, len(workers - {None}))
    with transaction() as session:
        session.execute(
            sa.update(Job)
            .where(Job.id == job_id, Job.status.in_(("queued", "running")))
            .values(
                status="done",
                message=message,
                finished_at=utcnow(),
                done=len(stimuli),
                total=len(stimuli),
            )
        )
    return "done"


def render_clip_standalone(job_id: int, stimulus_id: int) -> dict[str, Any]:
    """Entry point of a clip job in the RQ worker."""

    with app_context(offline_app()):
        return render_clip(job_id, stimulus_id)


def finish_render_standalone(job_id: int, kept: int) -> str:
    """Entry point of the closing job in the RQ worker."""

    with app_context(offline_app()):
        return finish_render(job_id, kept)
