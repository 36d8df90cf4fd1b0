"""The local job runner: a spawned process, never a fork or a thread of the web process (a
forked child inherits the parent's GL context and hangs in it); a process that dies marks its
row failed."""

import time
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool

import sqlalchemy as sa

from app import jobs
from app.extensions import db
from app.models import Job


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
            row = db.session.execute(sa.select(Job.status, Job.message)
                                     .where(Job.id == job_id)).one()
            if row.status == "failed":
                break
            time.sleep(0.1)
        assert "generate the tracks first" in row.message
