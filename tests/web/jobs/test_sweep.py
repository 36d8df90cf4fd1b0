"""The sweeper: a job whose runner is gone (no sign of life, lost or failed in RQ) ends failed with
the reason, on the study page and in the job status it polls."""

import datetime as dt

from app.web.models import utcnow
from tests.support.jobrows import add_job, job_row


def test_running_job_without_a_sign_of_life_is_swept(app, client, web):
    study_id = web.study(video=False)
    silent = add_job(
        app,
        study_id,
        status="running",
        done=4,
        total=16,
        heartbeat_at=utcnow() - dt.timedelta(hours=1),
    )
    alive = add_job(app, study_id, status="running", done=1, total=16, heartbeat_at=utcnow())
    queued = add_job(app, study_id)
    web.login(client)
    page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    status, message = job_row(app, silent)
    assert status == "failed" and message.startswith("no sign of life for over 900 s")
    assert message in page and f"/jobs/{silent}/retry" in page
    assert job_row(app, alive)[0] == "running" and job_row(app, queued)[0] == "queued"
    # The progress API the page polls sweeps too.
    app.config["JOB_STALE_AFTER_SECONDS"] = 0
    assert client.get(f"/api/v1/jobs/{alive}").json["status"] == "failed"


def test_job_the_queue_lost_is_swept(app, client, web, redis_url):
    app.config["REDIS_URL"] = redis_url
    study_id = web.study(video=False)
    lost = add_job(app, study_id, status="running", heartbeat_at=utcnow())
    web.login(client)
    client.get(f"/experimenter/studies/{study_id}")
    status, message = job_row(app, lost)
    assert status == "failed" and message.startswith("the job queue lost it")


def test_a_job_rq_reports_failed_is_swept_with_its_error(app, client, web, redis_url):
    """The failure callback could not write the row (the database was away): the sweeper
    names RQ's error instead."""
    from redis import Redis
    from rq import Queue, SimpleWorker

    from app.web.jobs.queue import QUEUE, rq_job_id
    from app.web.jobs.worker import PromptShutdown

    class BurstWorker(PromptShutdown, SimpleWorker):
        """The job in this process; its shutdown as prompt as ``facepair worker``'s (RQ's own
        sometimes waited 60 s for its command thread)."""

    app.config["REDIS_URL"] = redis_url
    study_id = web.study(video=False)
    job_id = add_job(app, study_id, status="running", heartbeat_at=utcnow())
    connection = Redis.from_url(redis_url)
    # this process's own database: jobs other tests queued and left would run in the burst
    # below (renders of studies long gone: a minute)
    connection.flushdb()
    queue = Queue(QUEUE, connection=connection)
    queue.enqueue("builtins.int", "not a number", job_id=rq_job_id(job_id))
    BurstWorker([queue], connection=connection).work(burst=True)
    connection.close()
    web.login(client)
    client.get(f"/experimenter/studies/{study_id}")
    status, message = job_row(app, job_id)
    assert status == "failed"
    assert message == (
        "the job queue reports it failed (ValueError: invalid literal for int() "
        "with base 10: 'not a number'); retry it"
    )
