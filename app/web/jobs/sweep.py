"""The sweeper: a study's unfinished jobs whose runner is gone end ``failed`` with the reason, so
that the study page never shows a dead job running and the experimenter can retry it. The study
page and the job status the page polls sweep first (:func:`sweep_study_jobs`).
"""

from __future__ import annotations

import datetime as dt
import re

import sqlalchemy as sa
from flask import current_app
from redis import Redis
from redis.exceptions import RedisError
from rq.exceptions import NoSuchJobError
from rq.job import Job as RQJob

from app.web.extensions import db
from app.web.jobs.queue import finish_job_id, rq_job_id
from app.web.jobs.rows import mark_failed
from app.web.models import Job, utcnow


def _rq_states(app_redis_url: str, ids: list[int]) -> dict[int, tuple[str, str] | None]:
    """RQ's status of each job and, for a failed one, the last line of its error (None: RQ no
    longer knows it)."""

    connection = Redis.from_url(app_redis_url, socket_connect_timeout=2, socket_timeout=5)

    def state_of(rq_id: str) -> tuple[str, str] | None:
        try:
            rq_job = RQJob.fetch(rq_id, connection=connection)
        except NoSuchJobError:
            return None
        state = rq_job.get_status()
        result = rq_job.latest_result() if state == "failed" else None
        # the exception's own line ("module.Error: text"), not SQL or links printed after it
        error = [
            line
            for line in ((result.exc_string if result else None) or "").splitlines()
            if re.match(r"[A-Za-z_][\w.]*: ", line)
        ]
        # RQ's JobStatus is a str enum: its value is the word
        return str(getattr(state, "value", state)), error[-1][:200] if error else ""

    states: dict[int, tuple[str, str] | None] = {}
    for job_id in ids:
        states[job_id] = state_of(rq_job_id(job_id))
        if states[job_id] is None or states[job_id][0] == "finished":  # type: ignore[index]
            # A render split into clip jobs (app.web.jobs.clips) lives on in its closing job.
            states[job_id] = state_of(finish_job_id(job_id)) or states[job_id]
    return states


def sweep_stale(study_id: int, *, stale_after: float, redis_url: str | None = None) -> int:
    """Mark failed the study's unfinished jobs whose runner is gone: RQ no longer has them or
    reports them failed; (any runner) running without a sign of life for ``stale_after``
    seconds; (local runner) queued while the web process holding it has not renewed its
    heartbeat for that long (it was restarted: its queue is gone). Returns how many rows
    were swept. A Redis outage sweeps nothing through RQ."""

    rows = db.session.execute(
        sa.select(Job.id, Job.status, sa.func.coalesce(Job.heartbeat_at, Job.created_at)).where(
            Job.study_id == study_id, Job.status.in_(("queued", "running"))
        )
    ).all()
    cutoff = utcnow() - dt.timedelta(seconds=stale_after)
    reasons: dict[int, str] = {}
    for job_id, status, last_sign in rows:
        if last_sign >= cutoff:
            continue
        if status == "running":
            reasons[job_id] = (
                f"no sign of life for over {stale_after:.0f} s: the process "
                "running it stopped; retry it"
            )
        elif not redis_url:  # RQ is asked about its own queue below
            reasons[job_id] = (
                f"never started: the process holding it has not answered "
                f"for over {stale_after:.0f} s (restarted?); retry it"
            )
    if redis_url and rows:
        try:
            states = _rq_states(redis_url, [r.id for r in rows if r.id not in reasons])
        except RedisError:
            states = {}
        for job_id, known in states.items():
            if known is None:
                reasons[job_id] = "the job queue lost it: its worker stopped; retry it"
            elif known[0] in ("failed", "stopped", "canceled"):
                why = f" ({known[1]})" if known[1] else ""
                reasons[job_id] = f"the job queue reports it {known[0]}{why}; retry it"
    return sum(mark_failed(job_id, reason) for job_id, reason in reasons.items())


def sweep_study_jobs(study_id: int) -> int:
    """:func:`sweep_stale` with the application's settings, committed."""
    swept = sweep_stale(
        study_id,
        stale_after=current_app.config["JOB_STALE_AFTER_SECONDS"],
        redis_url=current_app.config.get("REDIS_URL"),
    )
    db.session.commit()
    return swept
