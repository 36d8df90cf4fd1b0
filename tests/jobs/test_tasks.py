"""Jobs whose process died: failure callbacks, the sweeper, heartbeats."""

import datetime as dt
import types

import sqlalchemy as sa

from app.extensions import db
from app.models import Job, utcnow


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


def test_running_job_without_a_sign_of_life_is_swept(app, client, web):
    study_id = web.study(video=False)
    silent = _job(app, study_id, status="running", done=4, total=16,
                  heartbeat_at=utcnow() - dt.timedelta(hours=1))
    alive = _job(app, study_id, status="running", done=1, total=16, heartbeat_at=utcnow())
    queued = _job(app, study_id)
    web.login(client)
    page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    status, message = _row(app, silent)
    assert status == "failed" and message.startswith("no sign of life for over 900 s")
    assert message in page and f"/jobs/{silent}/retry" in page
    assert _row(app, alive)[0] == "running" and _row(app, queued)[0] == "queued"
    # The progress API the page polls sweeps too.
    app.config["JOB_STALE_AFTER_SECONDS"] = 0
    assert client.get(f"/api/v1/jobs/{alive}").json["status"] == "failed"


def test_job_the_queue_lost_is_swept(app, client, web, redis_url):
    app.config["REDIS_URL"] = redis_url
    study_id = web.study(video=False)
    lost = _job(app, study_id, status="running", heartbeat_at=utcnow())
    web.login(client)
    client.get(f"/experimenter/studies/{study_id}")
    status, message = _row(app, lost)
    assert status == "failed" and message.startswith("the job queue lost it")


def test_rq_failure_callback_marks_the_row(app, web, monkeypatch):
    from app.jobs import tasks

    monkeypatch.setenv("DATABASE_URL", app.config["SQLALCHEMY_DATABASE_URI"])
    monkeypatch.setenv("MEDIA_ROOT", app.config["MEDIA_ROOT"])
    job_id = _job(app, web.study(video=False), status="running", heartbeat_at=utcnow())
    rq_job = types.SimpleNamespace(args=[job_id])
    tasks.rq_failed(rq_job, None, RuntimeError, RuntimeError("work horse killed"), None)
    assert _row(app, job_id) == ("failed", "RuntimeError: work horse killed")
    # A finished job is never overwritten.
    with app.app_context():
        assert not tasks.mark_failed(job_id, "again")


def test_run_job_keeps_a_heartbeat(app, web, monkeypatch):
    from app.jobs import tasks

    beats = []

    def slow(study, progress):
        for i in range(3):
            progress(i, 3)
            beats.append(db.session.scalar(sa.select(Job.heartbeat_at)))
        return "ok"

    monkeypatch.setitem(tasks.TASKS, "render", slow)
    job_id = _job(app, web.study(video=False))
    with app.app_context():
        assert tasks.run_job(job_id) == "done"
    assert beats[0] is not None and all(b is not None for b in beats)
