"""The RQ worker that ``facepair worker`` runs: RQ's own, with a warm shutdown that ends in
about a second.

RQ listens for commands (shut down, stop a job) on a pub/sub thread that waits up to 60 s for
each message. At a warm shutdown RQ unsubscribes, then joins that thread; redis-py (8.x) joins
without a limit, and once the thread has read the unsubscribe reply it waits the whole 60 s
for a subscription that never comes. An idle worker asked to stop (``systemctl stop``,
``docker stop``, a deploy) then hung for up to a minute, long enough for a supervisor's grace
period to end in SIGKILL, leaving the worker registered in Redis.

Here the thread looks at its stop flag every :data:`COMMAND_POLL_SECONDS`; a command still
arrives at once (the wait ends when a message does).
"""

from __future__ import annotations

from rq import Worker as RQWorker

#: Longest the pub/sub thread waits for a command before it looks at its stop flag: the
#: bound on a warm shutdown's wait for it. A wake-up costs one idle read, nothing in Redis.
COMMAND_POLL_SECONDS = 1.0


class PromptShutdown:
    """Mixin for RQ's worker classes: the command thread wakes every
    :data:`COMMAND_POLL_SECONDS` instead of every 60 s."""

    def subscribe(self):  # type: ignore[no-untyped-def]
        """RQ's ``Worker.subscribe`` with the shorter wait."""
        self.log.info("Worker %s: subscribing to channel %s", self.name, self.pubsub_channel_name)
        self.pubsub = self.connection.pubsub()
        self.pubsub.subscribe(**{self.pubsub_channel_name: self.handle_payload})
        self.pubsub_thread = self.pubsub.run_in_thread(
            sleep_time=COMMAND_POLL_SECONDS,
            daemon=True,
            # RQ's retry on a lost connection, where the installed RQ has one
            exception_handler=getattr(self, "_pubsub_exception_handler", None),
        )


class Worker(PromptShutdown, RQWorker):
    """What ``facepair worker`` runs: RQ's worker (each job in a forked work horse)."""
