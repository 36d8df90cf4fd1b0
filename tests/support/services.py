"""Starting the development services, PostgreSQL and Redis on 127.0.0.1, when they are down.

One place for the commands and ports that the tests (``tests/conftest.py``) and the benchmarks
(``benchmarks/bench_load.py``, ``benchmarks/chaos_services.py``) rely on. Nothing here is part
of the application.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import time
from pathlib import Path

#: Where the services are, from the environment (defaults: this machine's usual ports), so two
#: suites or benchmarks on one host can each be pointed at their own.
PG_HOST = os.environ.get("FACEPAIR_TEST_PG_HOST", "127.0.0.1")
PG_PORT = int(os.environ.get("FACEPAIR_TEST_PG_PORT", "5432"))
REDIS_PORT = int(os.environ.get("FACEPAIR_TEST_REDIS_PORT", "6379"))
#: The prefix of the throwaway PostgreSQL databases a run creates (and drops).
PG_DATABASE_PREFIX = os.environ.get("FACEPAIR_TEST_DB_PREFIX", "facepair_test")


def redis_databases() -> tuple[int, int]:
    """The two Redis databases a test process may flush: ``FACEPAIR_TEST_REDIS_DB`` (default
    15) and the one below it, moved down by two for each further pytest-xdist worker (gw1 takes
    13 and 12), so parallel workers never flush each other's."""
    base = int(os.environ.get("FACEPAIR_TEST_REDIS_DB", "15"))
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    index = int(worker[2:]) if worker[2:].isdigit() else 0
    first = base - 2 * index
    if first < 1:
        raise RuntimeError(f"no Redis database left for xdist worker {worker} below {base}")
    return first, first - 1


def port_open(port: int, host: str = "127.0.0.1") -> bool:
    """Whether something accepts TCP connections on ``host:port``."""
    with socket.socket() as sock:
        sock.settimeout(0.5)
        return sock.connect_ex((host, port)) == 0


def wait_for_port(port: int, seconds: float = 60.0) -> bool:
    """Poll ``127.0.0.1:port`` until it answers (True) or ``seconds`` pass (False)."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if port_open(port):
            return True
        time.sleep(0.1)
    return False


def ensure_services(*, redis: bool = True, seconds: float = 5.0) -> bool:
    """Start the local PostgreSQL cluster (and Redis) if they are down; returns whether
    PostgreSQL answers within ``seconds``. The commands are those DEVELOPERS use by hand."""
    if not port_open(PG_PORT) and Path("/etc/postgresql").is_dir():
        version = sorted(p.name for p in Path("/etc/postgresql").iterdir())[-1]
        subprocess.run(
            ["pg_ctlcluster", "--skip-systemctl-redirect", version, "main", "start"],
            check=False,
            capture_output=True,
        )
    if redis and not port_open(REDIS_PORT) and shutil.which("redis-server"):
        subprocess.run(
            [
                "redis-server",
                "--daemonize",
                "yes",
                "--bind",
                "127.0.0.1",
                "--port",
                str(REDIS_PORT),
                "--save",
                "",
                "--appendonly",
                "no",
            ],
            check=False,
            capture_output=True,
        )
    return wait_for_port(PG_PORT, seconds)


def process_stat(pid: int) -> tuple[str, str, int, float]:
    """(command name, state, parent pid, user + system CPU seconds) of a process, from
    ``/proc/<pid>/stat``; OSError if it is gone. The name is in parentheses and may hold
    spaces, so the fields are counted from its closing one."""
    stat = Path(f"/proc/{pid}/stat").read_text()
    name = stat[stat.index("(") + 1 : stat.rindex(")")]
    fields = stat[stat.rindex(")") + 1 :].split()
    cpu = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return name, fields[0], int(fields[1]), cpu


def processes() -> dict[int, tuple[str, str, int, float]]:
    """:func:`process_stat` of every live process, by pid (one that exits meanwhile is left
    out)."""
    found = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                found[int(entry.name)] = process_stat(int(entry.name))
            except (OSError, ValueError):
                continue
    return found
