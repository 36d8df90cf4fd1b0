"""The RQ queue the jobs go on when ``REDIS_URL`` is set: its name, how long a job may run on it,
and the RQ ids of a row's jobs, by which the sweeper asks RQ about them (:func:`rq_job_id`; a
render split into one job per clip, :mod:`app.web.jobs.clips`, adds :func:`clip_job_id` and
:func:`finish_job_id`).
"""

from __future__ import annotations

QUEUE = "facepair"
#: Longest a job may run in RQ before it is stopped (a study's whole render).
JOB_TIMEOUT = 6 * 3600


def rq_job_id(job_id: int) -> str:
    """The RQ job id of row ``job_id`` (so the sweeper can ask RQ about it)."""
    return f"facepair-job-{job_id}"


def clip_job_id(job_id: int, stimulus_id: int) -> str:
    """The RQ id of the job rendering stimulus ``stimulus_id`` for render row ``job_id``."""

    return f"{rq_job_id(job_id)}-clip-{stimulus_id}"


def finish_job_id(job_id: int) -> str:
    """The RQ id of the job that ends render row ``job_id`` once its clip jobs have ended."""

    return f"{rq_job_id(job_id)}-finish"
