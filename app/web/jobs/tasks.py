"""What runs in a job runner's own process, beside the web application: RQ's job and failure
callback, started by name (queued jobs carry ``app.web.jobs.tasks.run_job_standalone`` and
``app.web.jobs.tasks.rq_failed``), each building its application (:mod:`app.web.standalone`);
the RQ worker's handler for a work horse that died; and the entry point of a process the local
runner spawns (:mod:`app.web.jobs`), which builds its application too.

The application's factory imports the blueprints, which enqueue jobs: no module the web
application imports imports this one, and the runners name these functions instead of importing
them. What a job does is in :mod:`app.web.jobs.bodies`.
"""

from __future__ import annotations

import os
from typing import Any

from app.web.extensions import db
from app.web.jobs.bodies import run_job
from app.web.jobs.rows import failure_message, mark_failed
from app.web.standalone import app_context, offline_app


def run_in_child(job_id: int, config: dict[str, Any]) -> str:
    """Entry point of a spawned job process: its own application, then the job."""
    with app_context(offline_app({**config, "JOB_RUNNER": "inline"})):
        return run_job(job_id)


def run_job_standalone(job_id: int) -> None:
    """Entry point for the RQ worker: builds the app from the environment."""
    with app_context(offline_app()):
        run_job(job_id)


def rq_failed(job, connection, exc_type, exc_value, traceback) -> None:  # type: ignore[no-untyped-def]
    """RQ's failure callback (an exception, a timeout, a killed work horse): the row says why."""
    reason = failure_message(exc_value) if exc_value is not None else "failed in the worker"
    with app_context(offline_app()):
        mark_failed(int(job.args[0]), reason)


def rq_horse_killed(job, retpid, ret_val, rusage) -> None:  # type: ignore[no-untyped-def]
    """The RQ worker's handler for a work horse that died (SIGKILL, out of memory): RQ calls
    no failure callback then, so the row is marked here, at once, with the signal."""

    how = (
        f"killed by signal {os.WTERMSIG(ret_val)}"
        if ret_val and os.WIFSIGNALED(ret_val)
        else f"exited with status {ret_val}"
    )
    try:
        mark_failed(int(job.args[0]), f"the process running it was {how}; retry it")
    finally:  # the worker forks the next work horse: it must hold no database connection
        db.session.remove()
        db.engine.dispose()
