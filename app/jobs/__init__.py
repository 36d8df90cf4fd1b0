"""Background jobs: generating tracks, rendering clips, regenerating reports.

A :class:`~app.models.Job` row records what runs and how far it got; :func:`enqueue` hands its
id to RQ when ``REDIS_URL`` is set, to a local worker thread otherwise (``JOB_RUNNER="inline"``
runs it at once, for tests). Always enqueue after the commit that created the row.
"""

from __future__ import annotations

import threading
from concurrent.futures import Future, ThreadPoolExecutor
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from flask import Flask

_local: ThreadPoolExecutor | None = None
_lock = threading.Lock()


def _local_executor() -> ThreadPoolExecutor:
    global _local
    with _lock:
        if _local is None:
            # One worker: jobs of a study run in the order they were asked for.
            _local = ThreadPoolExecutor(max_workers=1, thread_name_prefix="facepair-job")
        return _local


def _run_in_app(app: Flask, job_id: int) -> None:
    from app.jobs.tasks import run_job

    with app.app_context():
        run_job(job_id)


def enqueue(app: Flask, job_id: int) -> Future[None] | None:
    """Start job ``job_id`` (already committed) on the configured runner."""
    runner = app.config.get("JOB_RUNNER", "thread")
    if app.config.get("REDIS_URL") and runner != "inline":
        from redis import Redis
        from rq import Queue

        queue = Queue("facepair", connection=Redis.from_url(app.config["REDIS_URL"]))
        queue.enqueue("app.jobs.tasks.run_job_standalone", job_id, job_timeout=6 * 3600)
        return None
    if runner == "inline":
        _run_in_app(app, job_id)
        return None
    return _local_executor().submit(_run_in_app, app, job_id)
