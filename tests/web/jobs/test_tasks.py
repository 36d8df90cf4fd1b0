"""What runs in a job runner's own process: RQ's failure callback marks the row failed with the
reason."""

import types

from app.web.models import utcnow
from tests.support.jobrows import add_job, job_row


def test_rq_failure_callback_marks_the_row(app, web, monkeypatch):
    from app.web.jobs import tasks

    monkeypatch.setenv("DATABASE_URL", app.config["SQLALCHEMY_DATABASE_URI"])
    monkeypatch.setenv("MEDIA_ROOT", app.config["MEDIA_ROOT"])
    job_id = add_job(app, web.study(video=False), status="running", heartbeat_at=utcnow())
    rq_job = types.SimpleNamespace(args=[job_id])
    tasks.rq_failed(rq_job, None, RuntimeError, RuntimeError("work horse killed"), None)
    assert job_row(app, job_id) == ("failed", "work horse killed")  # no exception name
    # A finished job is never overwritten.
    with app.app_context():
        assert not tasks.mark_failed(job_id, "again")
