"""The processes the fault checks start, stop and kill: a private PostgreSQL cluster, a private
Redis, gunicorn (``facepair serve``) and an RQ worker (``facepair worker``). Everything listens
on 127.0.0.1 only. Used by ``benchmarks/chaos.py`` and its slice in ``tests/test_chaos.py``.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

from tests.support import services

ROOT = Path(__file__).resolve().parent.parent


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def wait_for_port(port: int, seconds: float = 60.0) -> None:
    if not services.wait_for_port(port, seconds):
        raise RuntimeError(f"nothing answers on 127.0.0.1:{port} after {seconds:.0f} s")


def children(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` and that are alive (from /proc).

    A child that has exited but is not yet reaped (a zombie, state Z or X) is left out: a work
    horse that finished its job is one for a moment, and a signal to it kills nothing.
    """
    return [
        child
        for child, (_, state, parent, _) in services.processes().items()
        if parent == pid and state not in ("Z", "X")
    ]


class PrivatePostgres:
    """A throwaway PostgreSQL cluster in ``folder`` (as user ``postgres`` when run as root)."""

    def __init__(self, folder: Path) -> None:
        self.data = folder / "pgdata"
        self.port = free_port()
        self.url = f"postgresql+psycopg://postgres@127.0.0.1:{self.port}/postgres"

    def _run(self, *args: str) -> None:
        command = [shutil.which(args[0]) or args[0], *args[1:]]
        if os.geteuid() == 0:
            command = ["runuser", "-u", "postgres", "--", *command]
        subprocess.run(command, check=True, capture_output=True)

    def create(self) -> None:
        self.data.mkdir(parents=True)
        if os.geteuid() == 0:
            os.chmod(self.data.parent, 0o755)
            shutil.chown(self.data, "postgres", "postgres")
        self._run("initdb", "-D", str(self.data), "-U", "postgres", "-A", "trust")
        self.start()

    def start(self) -> None:
        options = f"-p {self.port} -k {self.data} -c listen_addresses=127.0.0.1"
        self._run(
            "pg_ctl",
            "-D",
            str(self.data),
            "-o",
            options,
            "-l",
            str(self.data / "server.log"),
            "-w",
            "start",
        )

    def stop(self) -> None:
        self._run("pg_ctl", "-D", str(self.data), "-m", "fast", "-w", "stop")


class PrivateRedis:
    """A Redis on its own port, persisting to ``folder`` (so an outage loses no queued job)."""

    def __init__(self, folder: Path) -> None:
        self.folder, self.port = folder, free_port()
        self.url = f"redis://127.0.0.1:{self.port}/0"
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        self.process = subprocess.Popen(
            [
                "redis-server",
                "--bind",
                "127.0.0.1",
                "--port",
                str(self.port),
                "--dir",
                str(self.folder),
                "--save",
                "",
                "--appendonly",
                "yes",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        wait_for_port(self.port)

    def stop(self) -> None:
        if self.process is not None:
            self.process.terminate()
            self.process.wait(timeout=30)
            self.process = None


class Command:
    """``python -m app <args>`` in its own session, logging to ``log``. Starting, stopping and
    killing hold one lock, so a supervisor restarting it never races a deliberate kill."""

    def __init__(self, args: list[str], env: dict[str, str], log: Path) -> None:
        self.args, self.env, self.log = args, env, log
        self.process: subprocess.Popen[bytes] | None = None
        self.lock = threading.RLock()

    def start(self) -> None:
        with self.lock, open(self.log, "ab") as out:
            if self.alive():
                return
            self.process = subprocess.Popen(
                [sys.executable, "-m", "app", *self.args],
                cwd=ROOT,
                env=self.env,
                stdout=out,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )

    @property
    def pid(self) -> int:
        assert self.process is not None
        return self.process.pid

    def alive(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def restart_if_exited(self) -> bool:
        """Start it again if it stopped on its own (not by :meth:`kill_all` or :meth:`stop`)."""
        with self.lock:
            if self.process is None or self.process.poll() is None:
                return False
            self.process = None
            self.start()
            return True

    def kill_all(self) -> None:
        """SIGKILL the whole process group (the command and everything it forked)."""
        with self.lock:
            if self.process is not None:
                try:
                    os.killpg(self.process.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                self.process.wait(timeout=30)
                self.process = None

    def stop(self) -> None:
        with self.lock:
            if self.alive():
                os.killpg(self.pid, signal.SIGTERM)
                try:
                    self.process.wait(timeout=30)  # type: ignore[union-attr]
                except subprocess.TimeoutExpired:
                    self.kill_all()
            self.process = None


def environment(
    database_url: str, redis_url: str, media: Path, instance: Path, stale_after: int
) -> dict[str, str]:
    """The deployment's environment, with a private instance folder holding its config."""
    instance.mkdir(parents=True, exist_ok=True)
    (instance / "config.py").write_text(
        f"JOB_STALE_AFTER_SECONDS = {stale_after}\nRETRY_AFTER_SECONDS = 1\n"
        # one client address stands for every participant: no per-address consent limit
        'CONSENT_LIMIT_PER_ADDRESS = ""\nCONSENT_LIMIT_PER_STUDY = ""\n'
    )
    return {
        **os.environ,
        "DATABASE_URL": database_url,
        "REDIS_URL": redis_url,
        "MEDIA_ROOT": str(media),
        "FACEPAIR_INSTANCE": str(instance),
        "SECRET_KEY": "chaos-" + os.urandom(16).hex(),
        "PYTHONPATH": str(ROOT),
    }


class Site(Command):
    """gunicorn serving the app; its workers can be SIGKILLed one at a time."""

    def __init__(self, env: dict[str, str], log: Path, workers: int) -> None:
        self.port = free_port()
        super().__init__(["serve", "--port", str(self.port), "--workers", str(workers)], env, log)

    def start(self) -> None:
        super().start()
        wait_for_port(self.port, 120)

    def workers(self) -> list[int]:
        return children(self.pid)


class JobWorker(Command):
    """``facepair worker``: its work horse (the process running a job) can be killed alone."""

    def __init__(self, env: dict[str, str], log: Path) -> None:
        super().__init__(["worker"], env, log)

    def horse(self) -> int | None:
        found = children(self.pid) if self.alive() else []
        return found[0] if found else None

    def kill_horse(self) -> bool:
        """SIGKILL the work horse and anything it started (RQ gives it its own group)."""
        with self.lock:
            horse = self.horse()
            if horse is None:
                return False
            try:
                os.killpg(horse, signal.SIGKILL)
            except ProcessLookupError:
                return False
            return True

    def kill_next_horse(self, seconds: float = 30.0) -> bool:
        """SIGKILL the next work horse to start, within ``seconds``; whether one was killed.

        Not the horse running now: it may be past its job's work already (its result being
        written), where a kill changes nothing, while a horse just forked is at the start of
        its job. A render is one RQ job per clip, so the next horse comes within a clip.
        """
        deadline = time.monotonic() + seconds
        running = self.horse()
        while time.monotonic() < deadline:
            horse = self.horse()
            if horse is not None and horse != running and self.kill_horse():
                return True
            time.sleep(0.005)
        return False

    def kill_all(self) -> None:
        with self.lock:
            self.kill_horse()
            super().kill_all()
