"""Job rows for the job tests: one made with given fields, and its status and message read
back, each in its own application context."""

from __future__ import annotations

from typing import Any

from flask import Flask

from app.web.extensions import db
from app.web.models import Job


def add_job(app: Flask, study_id: int, **fields: Any) -> int:
    """A render job of ``study_id`` with ``fields`` (status, done, heartbeat_at, ...); its id."""
    with app.app_context():
        job = Job(study_id=study_id, kind="render", **fields)
        db.session.add(job)
        db.session.commit()
        return job.id


def job_row(app: Flask, job_id: int) -> tuple[str, str | None]:
    """The job's status and message as stored."""
    with app.app_context():
        job = db.session.get(Job, job_id)
        assert job is not None
        return job.status, job.message
