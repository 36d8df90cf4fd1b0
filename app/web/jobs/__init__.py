"""Background jobs: generating tracks, rendering clips, regenerating reports.

A :class:`~app.web.models.Job` row records what runs and how far it got; :func:`enqueue` hands its
id to a runner, always after the commit that created the row:

* RQ when ``REDIS_URL`` is set: a separate ``facepair worker`` process picks it up; the RQ job
  id is :func:`rq_job_id` and a failure callback marks the row failed with the reason;
* otherwise a *spawned* local process (``JOB_RUNNER="process"``, the default): never a thread
  or a fork of the web process, because a forked child inherits the parent's GL context and
  hangs in it, and a render thread would stall the process answering participants;
* ``JOB_RUNNER="inline"`` runs it at once in this process (tests).

Rows whose runner died are found by :func:`app.web.jobs.sweep.sweep_stale` and can be retried. A
row waiting in a local runner's queue is kept alive by the web process holding it (a heartbeat
thread, :func:`beat_held`): if that process is restarted its queue is gone, the beats stop and
the sweeper fails the row instead of leaving it queued forever.

A spawned process and RQ take the job's entry point by its name
(:mod:`app.web.jobs.tasks`), never imported here: each builds its own application, whose
factory imports the blueprints, which import this package to enqueue jobs.
"""

from __future__ import annotations

import functools
import importlib
import logging
import multiprocessing
import threading
import time
from concurrent.futures import Future, ProcessPoolExecutor
from typing import TYPE_CHECKING, Any

from app.web.jobs.queue import JOB_TIMEOUT, QUEUE, rq_job_id

if TYPE_CHECKING:
    from flask import Flask

#: The entry point of a spawned job process (its application, then the job).
CHILD_ENTRY = "app.web.jobs.tasks.run_in_child"
#: Configuration a spawned job process needs to build its own application.
CHILD_CONFIG = ("SQLALCHEMY_DATABASE_URI", "SQLALCHEMY_ENGINE_OPTIONS", "MEDIA_ROOT", "TESTING")

_local: ProcessPoolExecutor | None = None
_lock = threading.Lock()
#: Rows this process handed to its local runner, until their process finishes.
_held: dict[int, tuple[Flask, Future[str]]] = {}
_keeper: threading.Thread | None = None
log = logging.getLogger(__name__)


class EnqueueError(RuntimeError):
    """The job could not be handed to its runner (e.g. Redis unreachable)."""


def _process_executor() -> ProcessPoolExecutor:
    global _local
    with _lock:
        if _local is None or getattr(_local, "_broken", False):
            # One worker: jobs of a study run in the order they were asked for. "spawn": a
            # fresh interpreter, never a fork holding the web process's state.
            _local = ProcessPoolExecutor(
                max_workers=1, mp_context=multiprocessing.get_context("spawn")
            )
        return _local


def _run_named(target: str, *args: Any) -> Any:
    """Call the function named ``target`` (``package.module.function``) with ``args``: what a
    spawned job process runs, importing the entry point there, as an RQ worker does."""
    module, _, name = target.rpartition(".")
    return getattr(importlib.import_module(module), name)(*args)


def _when_finished(app: Flask, job_id: int, future: Future[str]) -> None:
    """Failure callback of the local runner: a process that died marks its row failed."""
    exc = future.exception()
    if exc is None:
        return
    from app.web.jobs.rows import mark_failed

    with app.app_context():
        mark_failed(job_id, f"the process running it stopped ({type(exc).__name__}: {exc})")


def beat_held() -> int:
    """Renew the heartbeat of every row still queued in this process's local runner; returns
    how many rows were renewed."""
    import sqlalchemy as sa
    from sqlalchemy.exc import SQLAlchemyError

    from app.web.extensions import db, transaction
    from app.web.models import Job, utcnow

    by_app: dict[int, tuple[Flask, list[int]]] = {}
    with _lock:
        for job_id, (app, future) in list(_held.items()):
            if future.done():
                del _held[job_id]
            else:
                by_app.setdefault(id(app), (app, []))[1].append(job_id)
    renewed = 0
    for app, held in by_app.values():
        with app.app_context():
            try:
                with transaction() as session:
                    result = session.execute(
                        sa.update(Job)
                        .where(Job.id.in_(held), Job.status == "queued")
                        .values(heartbeat_at=utcnow())
                    )
                renewed += int(result.rowcount or 0)
            except SQLAlchemyError:  # the database is away: the next beat tries again
                log.warning("could not renew the heartbeat of queued jobs %s", held)
            finally:
                db.session.remove()
    return renewed


def _keep_held_alive(interval: float) -> None:
    while True:
        time.sleep(interval)
        beat_held()


def _hold(app: Flask, job_id: int, future: Future[str]) -> None:
    """Keep row ``job_id`` alive while it waits in this process's queue."""
    global _keeper
    from app.web.jobs.rows import beat_interval

    with _lock:
        _held[job_id] = (app, future)
        if _keeper is None or not _keeper.is_alive():
            interval = beat_interval(app.config.get("JOB_STALE_AFTER_SECONDS", 900))
            _keeper = threading.Thread(
                target=_keep_held_alive, args=(interval,), name="facepair-queued-jobs", daemon=True
            )
            _keeper.start()


def enqueue(app: Flask, job_id: int) -> Future[str] | None:
    """Start job ``job_id`` (already committed) on the configured runner; raises
    :class:`EnqueueError` when the runner cannot take it."""
    runner = app.config.get("JOB_RUNNER", "process")
    if app.config.get("REDIS_URL") and runner != "inline":
        from redis import Redis
        from redis.exceptions import RedisError
        from rq import Callback, Queue

        connection = Redis.from_url(
            app.config["REDIS_URL"], socket_connect_timeout=5, socket_timeout=10
        )
        try:
            Queue(QUEUE, connection=connection).enqueue(
                "app.web.jobs.tasks.run_job_standalone",
                job_id,
                job_id=rq_job_id(job_id),
                job_timeout=JOB_TIMEOUT,
                on_failure=Callback("app.web.jobs.tasks.rq_failed"),
            )
        except RedisError as exc:
            raise EnqueueError(f"the job queue (REDIS_URL) is unreachable: {exc}") from None
        return None
    if runner == "inline":
        from app.web.jobs.bodies import run_job

        with app.app_context():
            run_job(job_id)
        return None
    from app.web.infra.media import DEFAULTS as MEDIA_SETTINGS

    config = {key: app.config[key] for key in (*CHILD_CONFIG, *MEDIA_SETTINGS) if key in app.config}
    future = _process_executor().submit(_run_named, CHILD_ENTRY, job_id, config)
    future.add_done_callback(functools.partial(_when_finished, app, job_id))
    _hold(app, job_id, future)
    return future
