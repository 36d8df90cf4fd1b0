"""The worker ``facepair worker`` runs: a warm shutdown is not held up by RQ's command
thread."""

import time

from redis import Redis

from app.web.jobs.worker import COMMAND_POLL_SECONDS, Worker


def test_a_warm_shutdown_does_not_wait_a_minute_for_the_command_thread(redis_url):
    """The race that held ``docker stop`` and the tests' workers for 60 s, made certain: the
    command thread has read the unsubscribe reply and waits for a subscription when the
    worker joins it. RQ's own worker took 59.8 s here; this one takes one poll."""
    with Redis.from_url(redis_url) as connection:
        worker = Worker(["facepair-test"], connection=connection)
        worker.subscribe()
        worker.pubsub.unsubscribe()
        deadline = time.monotonic() + 10
        while worker.pubsub.subscribed and time.monotonic() < deadline:
            time.sleep(0.01)
        assert not worker.pubsub.subscribed
        time.sleep(0.2)  # the thread is back in its wait
        start = time.monotonic()
        worker.unsubscribe()
        waited = time.monotonic() - start
    assert not worker.pubsub_thread.is_alive()
    assert waited < COMMAND_POLL_SECONDS + 10, waited  # a loaded machine's margin, not 60 s


def test_commands_still_reach_the_worker(redis_url):
    """The shorter wait keeps the command channel: a shutdown command sent to the worker by
    name reaches its handler (recorded here, not run: RQ's handler signals this process)."""
    from rq.command import send_shutdown_command

    received: list[dict] = []
    with Redis.from_url(redis_url) as connection:
        worker = Worker(["facepair-test"], connection=connection, name="prompt-test")
        worker.handle_payload = received.append  # bound at subscription
        worker.subscribe()
        try:
            time.sleep(0.2)
            send_shutdown_command(connection, worker.name)
            deadline = time.monotonic() + 10
            while not received and time.monotonic() < deadline:
                time.sleep(0.01)
        finally:
            worker.unsubscribe()
    assert [m["channel"] for m in received] == [b"rq:pubsub:prompt-test"], received
    assert b"shutdown" in received[0]["data"]
