"""A study's render split into one RQ job per clip: two real ``facepair worker`` processes
render one study's clips at once, the row sums their progress and ends done; a failing clip
fails the row with its name, and the clips behind it skip."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import sqlalchemy as sa

from app.web import jobs
from app.web.extensions import db
from app.web.infra.storage import media_dir
from app.web.jobs.queue import clip_job_id, finish_job_id
from app.web.models import Job, Stimulus, Study
from tests.conftest import create_test_study, make_app, upgrade_database, wipe_database
from tests.support.services import redis_databases

ROOT = Path(__file__).resolve().parents[3]
# Three conditions, every ordered pair: six small clips (64 px, half a second).
EXTRA = """
[render]
size = 64
mosaic_block = 16

[[conditions]]
name = "calm"
model = "random"
settings = { octaves = 1 }
"""


@pytest.fixture
def pg_app(postgres_url, redis_url, tmp_path):
    """The app on the test PostgreSQL (workers in other processes share it) with RQ jobs, on
    a Redis database of its own: the other job tests empty theirs."""
    from redis import Redis

    redis_url = redis_url.rsplit("/", 1)[0] + f"/{redis_databases()[1]}"

    with Redis.from_url(redis_url) as connection:
        connection.flushdb()  # no queued job of another run
    upgrade_database(postgres_url, tmp_path / "media")
    app = make_app(
        postgres_url,
        tmp_path / "media",
        REDIS_URL=redis_url,
        JOB_RUNNER="process",
        JOB_STALE_AFTER_SECONDS=60,
    )
    try:
        yield app
    finally:
        wipe_database(app)
        with Redis.from_url(redis_url) as connection:
            connection.flushdb()  # job ids start again with the next database


def start_worker(app, name: str, log: Path) -> subprocess.Popen:
    env = {
        **os.environ,
        "DATABASE_URL": app.config["SQLALCHEMY_DATABASE_URI"],
        "REDIS_URL": app.config["REDIS_URL"],
        "MEDIA_ROOT": app.config["MEDIA_ROOT"],
        "FACEPAIR_INSTANCE": str(log.parent / f"instance-{name}"),
        "PYTHONPATH": str(ROOT),
    }
    with log.open("wb") as out:  # the worker holds its own copy of the descriptor
        return subprocess.Popen(
            [sys.executable, "-m", "app", "worker", "--name", name],
            env=env,
            stdout=out,
            stderr=subprocess.STDOUT,
            cwd=ROOT,
        )


def stop(workers: list[subprocess.Popen]) -> list[int]:
    """SIGTERM (a warm shutdown) to each worker; the ones that had to be killed after 20 s
    are returned by index."""
    for worker in workers:
        if worker.poll() is None:
            worker.send_signal(signal.SIGTERM)
    killed = []
    for i, worker in enumerate(workers):
        try:
            worker.wait(timeout=20)
        except subprocess.TimeoutExpired:
            worker.kill()
            worker.wait()
            killed.append(i)
    return killed


def run_render(app, study_id: int, seconds: float = 240.0) -> tuple[Job, list[tuple[int, int]]]:
    """Queue the study's tracks and render and wait for the render row to end; returns it and
    the (done, total) values seen on the way."""
    seen: list[tuple[int, int]] = []
    with app.app_context():
        for kind in ("generate", "render"):
            job = Job(study_id=study_id, kind=kind)
            db.session.add(job)
            db.session.commit()
            jobs.enqueue(app, job.id)
            deadline = time.monotonic() + seconds
            while time.monotonic() < deadline:
                db.session.expire_all()
                row = db.session.get(Job, job.id)
                if (row.done, row.total) not in seen[-1:] and kind == "render":
                    seen.append((row.done, row.total))
                if row.status in ("done", "failed"):
                    break
                time.sleep(0.1)
            assert row.status == "done", (kind, row.status, row.message)
        db.session.expunge(row)
        return row, seen


@pytest.mark.postgres
@pytest.mark.slow
def test_two_workers_render_one_studys_clips_in_parallel(pg_app, tmp_path):
    from redis import Redis
    from rq.job import Job as RQJob

    study_id = create_test_study(pg_app, tmp_path, None, status="draft", extra=EXTRA)
    workers = [start_worker(pg_app, name, tmp_path / f"{name}.log") for name in ("w1", "w2")]
    try:
        row, seen = run_render(pg_app, study_id)
    finally:
        killed = stop(workers)
    # idle after the render, both stop on SIGTERM: none hangs in its command thread
    assert not killed, [(tmp_path / f"w{i + 1}.log").read_text()[-2000:] for i in killed]
    with pg_app.app_context():
        study = db.session.get(Study, study_id)
        stimuli = db.session.scalars(
            sa.select(Stimulus).where(Stimulus.study_id == study_id).order_by(Stimulus.id)
        ).all()
        assert len(stimuli) >= 4 and study.status == "ready"
        for stimulus in stimuli:
            assert (media_dir(study) / stimulus.video_path).stat().st_size > 1000
    with Redis.from_url(pg_app.config["REDIS_URL"]) as connection:
        clip_jobs = [RQJob.fetch(clip_job_id(row.id, s.id), connection=connection) for s in stimuli]
        finished = RQJob.fetch(finish_job_id(row.id), connection=connection)
    by = {job.id: job.return_value() for job in clip_jobs}
    assert all(outcome["rendered"] for outcome in by.values()), by
    assert {outcome["worker"] for outcome in by.values()} == {"w1", "w2"}, by
    # at once, not in turn: some clip of one worker was rendering while one of the other was
    spans = {
        name: [(j.started_at, j.ended_at) for j in clip_jobs if j.worker_name == name]
        for name in ("w1", "w2")
    }
    assert any(a0 < b1 and b0 < a1 for a0, a1 in spans["w1"] for b0, b1 in spans["w2"]), spans
    assert row.message == f"{len(stimuli)} clips rendered by 2 workers"
    assert (row.done, row.total) == (len(stimuli), len(stimuli))
    # the page's k of n went up clip by clip, summed over both workers
    assert seen[-1] == (len(stimuli), len(stimuli)) and len(seen) >= 3, seen
    assert [done for done, _ in seen] == sorted(done for done, _ in seen)
    assert finished.return_value() == "done"


def test_a_failing_clip_fails_the_row_by_name_and_the_rest_skip(app, web, monkeypatch):
    """Inside one process: the clip jobs' bodies, as a worker runs them."""
    import renderer
    from app.web.jobs.bodies import generate_tracks
    from app.web.jobs.clips import finish_render, render_clip

    study_id = web.study(video=False)
    with app.app_context():
        generate_tracks(db.session.get(Study, study_id), lambda done, total: None)
        job = Job(study_id=study_id, kind="render", status="running", total=2)
        db.session.add(job)
        db.session.commit()
        job_id = job.id
        ids = list(
            db.session.scalars(
                sa.select(Stimulus.id).where(Stimulus.study_id == study_id).order_by(Stimulus.id)
            )
        )

    def broken(*args, **kwargs):
        raise RuntimeError("the GPU went away")

    monkeypatch.setattr(renderer, "render_pair", broken)
    with app.app_context():
        first = render_clip(job_id, ids[0])
        rest = [render_clip(job_id, i) for i in ids[1:]]
        row = db.session.get(Job, job_id)
        assert row.status == "failed"
        assert row.message.startswith("clip s1 ") and "the GPU went away" in row.message
        assert first["failed"] and all(r["skipped"] == "failed" for r in rest)
        assert finish_render(job_id, 0) == "failed"  # already ended: left as it is


def test_the_closing_job_fails_a_render_with_clips_missing(app, web):
    study_id = web.study(video=False)
    with app.app_context():
        job = Job(study_id=study_id, kind="render", status="running")
        db.session.add(job)
        db.session.commit()
        from app.web.jobs.bodies import generate_tracks
        from app.web.jobs.clips import finish_render

        generate_tracks(db.session.get(Study, study_id), lambda done, total: None)
        assert finish_render(job.id, 0) == "failed"
        db.session.expire_all()
        total = db.session.scalar(sa.select(sa.func.count(Stimulus.id)))
        assert db.session.get(Job, job.id).message == (
            f"0 of {total} clips rendered; retry it to render the rest"
        )


def test_a_split_render_waiting_for_workers_is_swept_only_when_rq_lost_it(app, web, redis_url):
    """Clips may wait behind other studies' clips for longer than the stale timeout: the row
    is queued, its closing job deferred in RQ, and the sweeper leaves it; once RQ no longer
    has the closing job the row is swept."""
    import datetime as dt

    from redis import Redis
    from rq import Queue
    from rq.job import Dependency

    from app.web.jobs.sweep import sweep_stale
    from app.web.models import utcnow

    redis_url = redis_url.rsplit("/", 1)[0] + f"/{redis_databases()[1]}"
    study_id = web.study(video=False)
    long_ago = utcnow() - dt.timedelta(hours=2)
    with app.app_context():
        job = Job(
            study_id=study_id,
            kind="render",
            status="queued",
            created_at=long_ago,
            heartbeat_at=long_ago,
        )
        db.session.add(job)
        db.session.commit()
        job_id = job.id
    with Redis.from_url(redis_url) as connection:
        connection.flushdb()
        queue = Queue("facepair-test-split", connection=connection)
        waiting = queue.enqueue("builtins.print", job_id=clip_job_id(job_id, 1))
        queue.enqueue(
            "builtins.print", job_id=finish_job_id(job_id), depends_on=Dependency(jobs=[waiting])
        )
        with app.app_context():
            assert sweep_stale(study_id, stale_after=60, redis_url=redis_url) == 0
            assert db.session.get(Job, job_id).status == "queued"
            connection.flushdb()  # Redis lost everything
            assert sweep_stale(study_id, stale_after=60, redis_url=redis_url) == 1
            db.session.commit()
            row = db.session.get(Job, job_id)
            assert row.status == "failed" and row.message.startswith("the job queue lost it")
