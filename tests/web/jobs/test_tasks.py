"""What runs in a job runner's own process: RQ's failure callback marks the row failed with the
reason."""

import types

from app.web.extensions import db
from app.web.models import Job, utcnow


def _job(app, study_id, **fields):
    with app.app_context():
        job = Job(study_id=study_id, kind="render", **fields)
        db.session.add(job)
        db.session.commit()
        return job.id


def _row(app, job_id):
    with app.app_context():
        job = db.session.get(Job, job_id)
        return job.status, job.message


def test_rq_failure_callback_marks_the_row(app, web, monkeypatch):
    from app.web.jobs import tasks

    monkeypatch.setenv("DATABASE_URL", app.config["SQLALCHEMY_DATABASE_URI"])
    monkeypatch.setenv("MEDIA_ROOT", app.config["MEDIA_ROOT"])
    job_id = _job(app, web.study(video=False), status="running", heartbeat_at=utcnow())
    rq_job = types.SimpleNamespace(args=[job_id])
    tasks.rq_failed(rq_job, None, RuntimeError, RuntimeError("work horse killed"), None)
    assert _row(app, job_id) == ("failed", "work horse killed")  # no exception name
    # A finished job is never overwritten.
    with app.app_context():
        assert not tasks.mark_failed(job_id, "again")
