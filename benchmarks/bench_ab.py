"""Saturated votes of two facepair checkouts, in alternating rounds on the same machine.

A change to the vote path is worth a few per cent at most, and two runs of ``bench_load.py``
on one build differ by more than that when the host's speed drifts. Here both builds serve at
once, each ``facepair serve`` (gunicorn 4 workers x 4 threads, as in ``bench_load.py``) on its
own fresh PostgreSQL database with the example study. Every participant is enrolled before the
first round, so the rounds time votes only; then each round drives one build and the other,
their order swapped every round, ``--saturate`` participants' 18 votes at a time from 64
senders, after an untimed warm-up round of each (its workers compile and prepare their
statements). Prints each round's votes per second and CPU per vote (server, PostgreSQL, load
generator, from ``/proc``), each build's median, and the second build's median as a multiple
of the first's. Two checkouts of the same build give 0.97-1.03 on two cores. Every vote must
be acknowledged; a lost one ends the run with status 1.

    git worktree add /tmp/before HEAD~1
    python benchmarks/bench_ab.py /tmp/before . --rounds 8
"""

from __future__ import annotations

import argparse
import asyncio
import os
import secrets
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks import load_clients  # noqa: E402
from benchmarks.bench_load import (  # noqa: E402
    PG,
    CpuMeter,
    check_ready,
    cpu_used,
    database_url,
    prepare,
    trials_of,
)
from tests.support.services import wait_for_port  # noqa: E402


def checkout(text: str) -> Path:
    """A facepair checkout's folder; ValueError naming what is missing otherwise."""
    folder = Path(text).resolve()
    if not (folder / "app" / "__main__.py").is_file():
        raise ValueError(f"{text}: not a facepair checkout (no app/__main__.py)")
    return folder


class Build:
    """One checkout served on its own database, its participants enrolled."""

    def __init__(self, name: str, folder: Path, port: int, admin: Any) -> None:
        self.name, self.folder, self.port, self.admin = name, folder, port, admin
        self.database = f"facepair_ab_{name.lower()}_{secrets.token_hex(3)}"
        admin.execute(f'CREATE DATABASE "{self.database}"')
        try:
            self._start(port)
        except BaseException:
            self.drop(admin)
            raise
        self.rates: list[float] = []
        self.cpu: list[dict[str, float]] = []

    def _start(self, port: int) -> None:
        self.url = database_url(PG, self.database)
        self.media = Path(os.environ.get("TMPDIR", "/tmp")) / self.database
        self.media.mkdir(parents=True)
        self.slug = prepare(self.url, self.media)
        env = {
            **os.environ,
            "DATABASE_URL": self.url,
            "MEDIA_ROOT": str(self.media),
            "SECRET_KEY": secrets.token_hex(16),
        }
        with open(self.media / "server.log", "ab") as log:
            self.server = subprocess.Popen(
                [sys.executable, "-m", "app", "serve", "--port", str(port), "--workers", "4"],
                env=env,
                stdout=log,
                stderr=subprocess.STDOUT,
                cwd=self.folder,
            )
        if not wait_for_port(port, 60):
            self.server.terminate()
            raise RuntimeError(
                f"{self.name}: the server did not start; see {self.media}/server.log"
            )

    def enrol(self, rounds: int, per_round: int) -> None:
        """Consent ``rounds`` x ``per_round`` participants; each round gets its own."""
        base = f"http://127.0.0.1:{self.port}"
        tokens = asyncio.run(
            load_clients.consent_many(base, self.slug, rounds * per_round, timeout=60)
        )
        rows = trials_of(self.url, tokens)
        self.rounds = []
        for first in range(0, len(tokens), per_round):
            mine = set(tokens[first : first + per_round])
            self.rounds.append(
                [
                    (
                        trial,
                        "left",
                        load_clients.vote_body(token, trial, "left", secrets.token_hex(8), 1500),
                    )
                    for token, trial in rows
                    if token in mine
                ]
            )

    def drive(self, index: int, warm_up: bool = False) -> bool:
        """Round ``index``'s votes, saturated (a warm-up's not counted); False if any went
        unacknowledged."""
        bodies = self.rounds[index]
        meter = CpuMeter(self.server.pid, self.admin, self.database)
        before = meter.read()
        tally, elapsed = asyncio.run(
            load_clients.saturate(
                f"http://127.0.0.1:{self.port}/api/v1/votes", bodies, concurrency=64, timeout=60
            )
        )
        spent = cpu_used(before, meter.read())
        rate = len(tally.acknowledged) / elapsed
        cpu = {k: v / len(bodies) * 1e3 for k, v in spent.items()}
        if not warm_up:
            self.rates.append(rate)
            self.cpu.append(cpu)
        used = ", ".join(f"{k} {v:.2f} ms" for k, v in cpu.items())
        label = "warm-up" if warm_up else f"round {index + 1}"
        print(f"{label}, {self.name}: {rate:.0f} votes/s; CPU per vote {used}")
        for error in tally.errors[:3]:
            print("  error:", error)
        return len(tally.acknowledged) == len(bodies)

    def summary(self) -> str:
        used = ", ".join(
            f"{k} {float(np.median([c[k] for c in self.cpu])):.2f} ms" for k in self.cpu[0]
        )
        return (
            f"{self.name} ({self.folder}): median {float(np.median(self.rates)):.0f} votes/s; "
            f"CPU per vote {used}"
        )

    def stop(self, admin: Any) -> None:
        self.server.terminate()
        self.server.wait(timeout=30)
        self.drop(admin)
        if sys.exc_info()[0] is None:  # a failed run keeps its server's log
            shutil.rmtree(self.media, ignore_errors=True)

    def drop(self, admin: Any) -> None:
        admin.execute(f'DROP DATABASE IF EXISTS "{self.database}" WITH (FORCE)')


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", help="the checkout to compare against (A)")
    parser.add_argument("second", help="the checkout measured against it (B)")
    parser.add_argument("--rounds", type=int, default=8, help="rounds of each build")
    parser.add_argument(
        "--saturate", type=int, default=120, help="participants (x 18 votes) per round"
    )
    parser.add_argument("--port", type=int, default=5200, help="A's port; B's is the next")
    args = parser.parse_args()
    try:
        folders = [checkout(args.first), checkout(args.second)]
    except ValueError as exc:
        parser.error(str(exc))
    check_ready(parser, args)
    import psycopg

    admin = psycopg.connect(f"{PG} dbname=postgres", autocommit=True)
    builds: list[Build] = []
    try:
        for name, folder in zip("AB", folders, strict=True):
            builds.append(Build(name, folder, args.port + len(builds), admin))
            builds[-1].enrol(args.rounds + 1, args.saturate)
        complete = True
        for build in builds:  # each worker compiles and prepares its statements: not timed
            complete = build.drive(args.rounds, warm_up=True) and complete
        for index in range(args.rounds):
            for build in builds if index % 2 == 0 else builds[::-1]:
                complete = build.drive(index) and complete
        for build in builds:
            print(build.summary())
        a, b = (float(np.median(build.rates)) for build in builds)
        print(f"B/A: {b / a:.3f} (median votes/s of {args.rounds} alternating rounds)")
        return 0 if complete else 1
    finally:
        for build in builds:
            build.stop(admin)
        admin.close()


if __name__ == "__main__":
    sys.exit(main())
