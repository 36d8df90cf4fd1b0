"""A slice of ``benchmarks/chaos.py`` in the suite, on the test PostgreSQL and the Redis at
127.0.0.1:6379: participants vote through a SIGKILLed gunicorn worker, and a render job run
by a real ``facepair worker`` (RQ) has its work horse killed, then the whole worker killed
and restarted, mid-job. No vote is lost or stored twice; each killed job ends failed with its
reason (at once for the work horse; after JOB_STALE_AFTER_SECONDS for the worker), and the
retry resumes from the clips already rendered."""

import secrets

import pytest
import sqlalchemy as sa

from benchmarks.chaos import Options, run


@pytest.fixture
def empty_database(postgres_url):
    server = postgres_url.rsplit("/", 1)[0]
    name = f"facepair_chaos_{secrets.token_hex(4)}"
    admin = sa.create_engine(f"{server}/postgres", isolation_level="AUTOCOMMIT")
    with admin.connect() as conn:
        conn.execute(sa.text(f'CREATE DATABASE "{name}"'))
    try:
        yield f"{server}/{name}"
    finally:
        with admin.connect() as conn:
            conn.execute(sa.text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()


@pytest.mark.slow
@pytest.mark.postgres
def test_votes_and_jobs_survive_a_worker_kill_and_job_kills(empty_database, redis_url, tmp_path):
    options = Options(
        participants=4,
        web_workers=2,
        worker_kills=1,
        db_down=0,
        redis_down=0,
        job_kills=("horse", "worker"),
        think=(0.05, 0.15),
        stale_after=4,
        span=6.0,
    )
    from redis import Redis

    with Redis.from_url(redis_url) as connection:
        connection.flushdb()  # no queued job or result of another run
    try:
        result = run(
            options,
            tmp_path,
            database_url=empty_database,
            redis_url=redis_url,
            echo=lambda *args: None,
        )
    finally:
        # nor of this run for the tests after it: the Redis fixture is flushed once a session,
        # and their job rows' ids (from 1 in each test's database) would name this run's RQ jobs
        with Redis.from_url(redis_url) as connection:
            connection.flushdb()
    assert result.faults["web-worker"] == 1
    assert not result.tally.failures, result.tally.failures
    assert result.acknowledged == result.stored == 4 * 18  # every trial of every participant
    assert (result.lost, result.duplicated, result.wrong, result.stuck) == (0, 0, 0, 0)
    assert len(result.kills) == 2, result.jobs
    (horse, horse_fate), (worker, worker_fate) = result.kills
    assert horse_fate.startswith("failed") and "killed by signal 9" in horse_fate
    assert worker_fate.startswith("failed") and "no sign of life for over 4 s" in worker_fate
    assert result.resumed, result.jobs
    assert "kept from before" in result.jobs[-1]
