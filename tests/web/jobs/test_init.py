"""The local job runner: a spawned process, never a fork or a thread of the web process (a
forked child inherits the parent's GL context and hangs in it); a process that dies marks its
row failed."""

import datetime as dt
import time
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool

import sqlalchemy as sa

from app.web import jobs
from app.web.extensions import db
from app.web.models import Job, utcnow


def test_a_process_that_died_marks_its_row_failed(app, web):
    study_id = web.study(video=False)
    with app.app_context():
        job = Job(study_id=study_id, kind="render", status="running", done=4, total=16)
        db.session.add(job)
        db.session.commit()
        job_id = job.id
    future: Future = Future()
    future.set_exception(BrokenProcessPool("A child process terminated abruptly"))
    jobs._when_finished(app, job_id, future)
    with app.app_context():
        job = db.session.get(Job, job_id)
        assert job.status == "failed"
        assert job.message.startswith("the process running it stopped (BrokenProcessPool")


def test_jobs_run_in_a_spawned_process(app, web):
    app.config["JOB_RUNNER"] = "process"
    study_id = web.study(video=False)
    with app.app_context():
        job = Job(study_id=study_id, kind="render")  # fails: no tracks generated yet
        db.session.add(job)
        db.session.commit()
        job_id = job.id
    future = jobs.enqueue(app, job_id)
    assert future.result(timeout=120) == "failed"
    assert jobs._process_executor()._mp_context.get_start_method() == "spawn"
    deadline = time.monotonic() + 10
    with app.app_context():
        while time.monotonic() < deadline:
            row = db.session.execute(
                sa.select(Job.status, Job.message).where(Job.id == job_id)
            ).one()
            if row.status == "failed":
                break
            time.sleep(0.1)
        assert "generate the tracks first" in row.message


def _queued(app, study_id: int, *, age: dt.timedelta) -> int:
    with app.app_context():
        job = Job(study_id=study_id, kind="render", created_at=utcnow() - age)
        db.session.add(job)
        db.session.commit()
        return job.id


def _status(app, job_id: int) -> tuple[str, str]:
    with app.app_context():
        row = db.session.execute(sa.select(Job.status, Job.message).where(Job.id == job_id)).one()
        return row.status, row.message


def test_a_queued_row_nobody_holds_is_swept(app, client, web):
    """The web process that queued it was restarted: its local queue went with it."""
    app.config["JOB_RUNNER"] = "process"
    study_id = web.study(video=False)
    orphan = _queued(app, study_id, age=dt.timedelta(hours=1))
    fresh = _queued(app, study_id, age=dt.timedelta(seconds=0))
    web.login(client)
    page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    status, message = _status(app, orphan)
    assert status == "failed" and message.startswith("never started: the process holding it")
    assert f"/jobs/{orphan}/retry" in page
    assert _status(app, fresh)[0] == "queued"


def test_a_queued_row_held_by_a_live_process_is_kept(app, client, web):
    app.config["JOB_RUNNER"] = "process"
    study_id = web.study(video=False)
    waiting = _queued(app, study_id, age=dt.timedelta(hours=1))
    held: Future = Future()  # still waiting in this process's queue
    jobs._hold(app, waiting, held)
    try:
        assert jobs.beat_held() == 1
        web.login(client)
        client.get(f"/experimenter/studies/{study_id}")
        assert _status(app, waiting)[0] == "queued"
    finally:
        held.set_result("done")
    assert jobs.beat_held() == 0  # a finished future is let go


def test_a_row_swept_while_queued_never_starts(app, web):
    from app.web.jobs.bodies import run_job
    from app.web.jobs.rows import mark_failed

    study_id = web.study(video=False)
    job_id = _queued(app, study_id, age=dt.timedelta(hours=1))
    with app.app_context():
        assert mark_failed(job_id, "never started")
        assert run_job(job_id) == "failed"
    assert _status(app, job_id) == ("failed", "never started")
