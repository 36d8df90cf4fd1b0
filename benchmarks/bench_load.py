"""Load benchmark: simulated participants against gunicorn + PostgreSQL, and a bare baseline.

Creates a fresh PostgreSQL database on 127.0.0.1:5432 (user postgres), migrates it, creates the
example study (app/data/examples: 4 conditions, all ordered pairs, 2 catch trials = 18 trials
per participant) with placeholder clips, and starts ``facepair serve`` (gunicorn, gthread) on it.

``--mode open`` (the default; ``benchmarks/load_clients.py``): for each count in
``--participants``, participants arrive at ``--arrival-rate`` per second (Poisson; by default all
within 10 s), each loads the trial page once, then asks for a play, watches the clip for
``--think`` seconds (the clip's length) and votes, for ``--trials`` trials, each vote's answer
carrying the next pair as it does for the browser: the request rate is the participants', as in a
Prolific study, not the server's. Prints vote, play and trial-page latency p50/p99, errors and the
peak number of participants present at once, and the vote and play latency of the steady state:
requests sent while at least 95 % of that peak were present. Then the vote endpoint alone is
driven saturated (64 senders, prepared votes of freshly consented participants); with
``--baseline`` the bare baseline (``benchmarks/bare_baseline.py``: Flask + psycopg, one INSERT per
request, the same gunicorn settings) is driven the same way, alternating with facepair for
``--rounds`` rounds each, and the median of facepair's saturated vote throughput is printed as a
fraction of the baseline's median. Each phase also prints where the CPU went, per trial (a play
and a vote, and the trial pages loaded) or per saturated vote: the server's processes,
PostgreSQL's and the load generator's, from ``/proc``.

``--mode closed`` (the earlier figure): every participant, in its own thread with its own
keep-alive connection, sends its next request as soon as the last one returns.

In both modes one vote in ten is posted twice (a retried request with the same idempotency key)
and one in twenty a third time with a new key (a double click). Afterwards the votes are counted
in the database: every acknowledged vote stored exactly once with the clicked choice. Exits 1
if any vote is lost or duplicated.

    python benchmarks/bench_load.py --mode open --participants 200,500,1000 --baseline
    python benchmarks/bench_load.py --mode closed --participants 200
"""

from __future__ import annotations

import argparse
import asyncio
import http.client
import json
import os
import re
import secrets
import shutil
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import urlencode

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks import load_clients  # noqa: E402
from tests.support.services import (  # noqa: E402
    PG_HOST,
    PG_PORT,
    ensure_services,
    processes,
    wait_for_port,
)

#: The PostgreSQL server on which the benchmarks create (and drop) their databases, as a libpq
#: connection string: ``--pg`` or ``FACEPAIR_BENCH_PG``, by default the tests' server
#: (``FACEPAIR_TEST_PG_HOST`` / ``FACEPAIR_TEST_PG_PORT``, 127.0.0.1:5432).
PG = os.environ.get("FACEPAIR_BENCH_PG", f"host={PG_HOST} port={PG_PORT} user=postgres")
#: The share of the peak number of participants present that counts as the steady state.
STEADY = 0.95


def prepare(url: str, media: Path) -> str:
    """Migrate the database, create the example study, open it; returns its slug."""
    import sqlalchemy as sa
    from flask_migrate import upgrade

    from app.trials.studyfile import loads_study
    from app.web import create_app
    from app.web.extensions import db
    from app.web.infra.accounts import create_user
    from app.web.infra.storage import media_dir
    from app.web.models import Stimulus
    from app.web.study.studies import create_study

    app = create_app(
        {
            "SQLALCHEMY_DATABASE_URI": url,
            "MEDIA_ROOT": str(media),
            "JOB_RUNNER": "inline",
            "REQUIRE_SECRET_KEY": False,
        }
    )
    with app.app_context():
        upgrade()
        owner = create_user("load@example.org", "load benchmark orchid tundra")
        db.session.commit()
        study_file = ROOT / "app" / "data" / "examples" / "study.toml"
        text = study_file.read_text(encoding="utf-8")
        study = create_study(owner, loads_study(text, base_dir=study_file.parent), source_toml=text)
        folder = media_dir(study) / "videos"
        folder.mkdir(parents=True, exist_ok=True)
        for stimulus in db.session.scalars(
            sa.select(Stimulus).where(Stimulus.study_id == study.id)
        ):
            (folder / f"{stimulus.id}.mp4").write_bytes(b"\0" * 1024)  # never played here
            stimulus.video_path = f"videos/{stimulus.id}.mp4"
        study.status = "open"
        study.target_participants = 10_000
        slug = study.slug
        db.session.commit()
        db.engine.dispose()
    return slug


class Participant(threading.Thread):
    """One participant's browser: consent, then trial page + vote until done."""

    def __init__(self, port: int, slug: str, start_gate: threading.Barrier) -> None:
        super().__init__(daemon=True)
        self.port, self.slug, self.gate = port, slug, start_gate
        self.cookies: dict[str, str] = {}
        self.vote_ms: list[float] = []
        self.page_ms: list[float] = []
        self.votes: list[tuple[int, str]] = []
        self.statuses: dict[int, int] = {}
        self.error: str | None = None

    def request(
        self,
        method: str,
        path: str,
        body: bytes | None = None,
        headers: dict[str, str] | None = None,
    ) -> tuple[int, dict[str, str], bytes]:
        head = dict(headers or {})
        if self.cookies:
            head["Cookie"] = "; ".join(f"{k}={v}" for k, v in self.cookies.items())
        for attempt in range(3):
            try:
                self.conn.request(method, path, body=body, headers=head)
                response = self.conn.getresponse()
                data = response.read()
                break
            except (ConnectionError, http.client.HTTPException):
                if attempt == 2:
                    raise
                self.conn.close()
                self.conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=60)
        for name, value in response.getheaders():
            if name.lower() == "set-cookie":
                key, _, rest = value.partition("=")
                self.cookies[key] = rest.split(";", 1)[0]
        return response.status, {k.lower(): v for k, v in response.getheaders()}, data

    def run(self) -> None:
        self.conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=60)
        try:
            self.gate.wait()
            self._take_part()
        except Exception as exc:  # reported by the main thread
            self.error = f"{type(exc).__name__}: {exc}"
        finally:
            self.conn.close()

    def _take_part(self) -> None:
        rng = np.random.default_rng(secrets.randbits(32))
        query = f"?PROLIFIC_PID=load{secrets.token_hex(4)}&STUDY_ID=load&SESSION_ID=s"
        status, _, page = self.request("GET", f"/s/{self.slug}{query}")
        token = re.search(rb'name="csrf_token"[^>]*value="([^"]+)"', page)
        if status != 200 or token is None:
            raise RuntimeError(f"consent page: HTTP {status}")
        form = urlencode({"csrf_token": token.group(1).decode(), "agree": "1"}).encode()
        status, head, _ = self.request(
            "POST",
            f"/s/{self.slug}{query}",
            form,
            {"Content-Type": "application/x-www-form-urlencoded"},
        )
        if status != 302:
            raise RuntimeError(f"consent: HTTP {status}")
        who = head["location"].split("/p/")[1].split("/")[0]
        while True:
            start = time.perf_counter()
            status, head, page = self.request("GET", f"/p/{who}/trial")
            self.page_ms.append((time.perf_counter() - start) * 1e3)
            if status == 302:
                return
            found = re.search(rb'data-trial-id="(\d+)"', page)
            if status != 200 or found is None:
                raise RuntimeError(f"trial page: HTTP {status}")
            trial = int(found.group(1))
            choice = str(rng.choice(["left", "right", "undecided"]))
            key = secrets.token_hex(8)
            repeats = (
                [key]
                + ([key] if rng.random() < 0.1 else [])
                + ([secrets.token_hex(8)] if rng.random() < 0.05 else [])
            )
            for k in repeats:
                body = json.dumps(
                    {
                        "token": who,
                        "trial_id": trial,
                        "choice": choice,
                        "plays": 1,
                        "watched_to_end": True,
                        "response_ms": int(rng.integers(800, 4000)),
                        "idempotency_key": k,
                    }
                ).encode()
                start = time.perf_counter()
                status, _, _ = self.request(
                    "POST", "/api/v1/votes", body, {"Content-Type": "application/json"}
                )
                self.vote_ms.append((time.perf_counter() - start) * 1e3)
                self.statuses[status] = self.statuses.get(status, 0) + 1
                if status not in (200, 201):
                    raise RuntimeError(f"vote: HTTP {status}")
            self.votes.append((trial, choice))


def count(url: str) -> dict[str, int]:
    import psycopg

    dsn = url.replace("postgresql+psycopg://", "postgresql://")
    with psycopg.connect(dsn) as conn:
        one = conn.execute
        return {
            "participants": one("SELECT count(*) FROM participant").fetchone()[0],
            "trials": one("SELECT count(*) FROM trial WHERE kind <> 'practice'").fetchone()[0],
            "votes": one("SELECT count(*) FROM vote").fetchone()[0],
            "unanswered": one(
                "SELECT count(*) FROM trial t WHERE t.kind <> 'practice' AND "
                "NOT EXISTS (SELECT 1 FROM vote v WHERE v.trial_id = t.id)"
            ).fetchone()[0],
            "duplicated": one(
                "SELECT count(*) FROM (SELECT trial_id FROM vote GROUP BY "
                "trial_id HAVING count(*) > 1) d"
            ).fetchone()[0],
        }


def stored_choices(url: str) -> dict[int, str]:
    import psycopg

    dsn = url.replace("postgresql+psycopg://", "postgresql://")
    with psycopg.connect(dsn) as conn:
        return dict(conn.execute("SELECT trial_id, choice FROM vote").fetchall())


def _pct(values: list[float]) -> str:
    v = np.asarray(values)
    return (
        f"p50 {np.percentile(v, 50):.1f} ms, p90 {np.percentile(v, 90):.1f} ms, "
        f"p99 {np.percentile(v, 99):.1f} ms, max {v.max():.1f} ms"
    )


def check(url: str, acknowledged: dict[int, str]) -> tuple[str, bool]:
    """Every acknowledged vote stored once with the clicked choice: a line and whether so."""
    counts = count(url)
    stored = stored_choices(url)
    lost = sum(1 for t in acknowledged if t not in stored)
    wrong = sum(1 for t, c in acknowledged.items() if t in stored and stored[t] != c)
    unanswered = sum(1 for t in stored if t not in acknowledged)
    line = (
        f"database: {counts['participants']} participants, {counts['votes']} votes; "
        f"acknowledged {len(acknowledged)}: lost {lost}, duplicated {counts['duplicated']}, "
        f"differing from the acknowledged choice {wrong}; stored without an acknowledgement "
        f"{unanswered}"
    )
    return line, lost == 0 and wrong == 0 and counts["duplicated"] == 0


def start_server(
    args: list[str], env: dict[str, str], port: int, log: Path
) -> subprocess.Popen[bytes]:
    with open(log, "ab") as out:
        server = subprocess.Popen(
            [sys.executable, *args], env=env, stdout=out, stderr=subprocess.STDOUT, cwd=ROOT
        )
    if not wait_for_port(port, 60):
        server.terminate()
        sys.exit(f"the server did not start; see {log}")
    return server


def stop_server(server: subprocess.Popen[bytes]) -> None:
    server.terminate()
    server.wait(timeout=30)


def run_closed(args: argparse.Namespace, participants: int, slug: str, url: str) -> bool:
    gate = threading.Barrier(participants + 1)
    people = [Participant(args.port, slug, gate) for _ in range(participants)]
    for p in people:
        p.start()
    gate.wait()
    start = time.perf_counter()
    for p in people:
        p.join()
    elapsed = time.perf_counter() - start
    errors = [p.error for p in people if p.error]
    vote_ms = [ms for p in people for ms in p.vote_ms]
    page_ms = [ms for p in people for ms in p.page_ms]
    statuses: dict[int, int] = {}
    for p in people:
        for code, n in p.statuses.items():
            statuses[code] = statuses.get(code, 0) + n
    print(
        f"closed loop: {participants} participants at once, gunicorn {args.workers} workers "
        f"x 4 threads, PostgreSQL, {elapsed:.1f} s from first consent to last vote"
    )
    print(
        f"vote requests: {len(vote_ms)} ({statuses.get(201, 0)} stored, "
        f"{statuses.get(200, 0)} repeats answered 'already stored'), "
        f"{len(vote_ms) / elapsed:.0f} per s; {_pct(vote_ms)}"
    )
    print(f"trial pages: {len(page_ms)}, {_pct(page_ms)}")
    line, ok = check(url, {trial: choice for p in people for trial, choice in p.votes})
    print(f"{line}; client errors {len(errors)}")
    for e in errors[:5]:
        print("  error:", e)
    return ok and not errors


def database_url(dsn: str, name: str) -> str:
    """The SQLAlchemy URL of database ``name`` on the server of libpq string ``dsn``."""
    from psycopg.conninfo import conninfo_to_dict

    parts = conninfo_to_dict(dsn)
    user, host = parts.get("user", "postgres"), parts.get("host", "127.0.0.1")
    return f"postgresql+psycopg://{user}@{host}:{parts.get('port', 5432)}/{name}"


class CpuMeter:
    """CPU seconds, process by process, of the server (gunicorn's master and workers), of the
    PostgreSQL backends connected to its database ``database`` (their PIDs from
    ``pg_stat_activity``: other databases' backends and the cluster's shared background
    processes are not counted) and of this process (the load generator)."""

    def __init__(self, server_pid: int, admin: Any, database: str) -> None:
        self.server_pid, self.admin, self.database = server_pid, admin, database

    def read(self) -> dict[str, dict[int, float]]:
        seen = processes()
        backends = {
            row[0]
            for row in self.admin.execute(
                "SELECT pid FROM pg_stat_activity WHERE datname = %s", (self.database,)
            )
        }

        def under_server(pid: int) -> bool:
            while pid > 1:
                if pid == self.server_pid:
                    return True
                pid = seen[pid][2] if pid in seen else 0
            return False

        used: dict[str, dict[int, float]] = {"server": {}, "postgres": {}, "generator": {}}
        for pid, (_, _, _, cpu) in seen.items():
            if pid == os.getpid():
                used["generator"][pid] = cpu
            elif pid in backends:
                used["postgres"][pid] = cpu
            elif under_server(pid):
                used["server"][pid] = cpu
        return used


def cpu_used(
    before: dict[str, dict[int, float]], after: dict[str, dict[int, float]]
) -> dict[str, float]:
    """CPU seconds of each group between two :meth:`CpuMeter.read`: a process started in
    between counts from zero; one that ended in between loses only its last stretch."""
    return {
        group: sum(cpu - before[group].get(pid, 0.0) for pid, cpu in after[group].items())
        for group in after
    }


def cpu_line(
    before: dict[str, dict[int, float]],
    after: dict[str, dict[int, float]],
    count: int,
    unit: str,
    elapsed: float,
) -> str:
    """Where the CPU of a phase went, per ``unit`` (a trial: its play and vote, and the trial
    pages loaded; or a vote)."""
    used = cpu_used(before, after)
    per = ", ".join(f"{k} {v / max(count, 1) * 1e3:.1f} ms" for k, v in used.items())
    busy = sum(used.values()) / max(elapsed, 1e-9) / (os.cpu_count() or 1)
    return f"  CPU per {unit}: {per}; the cores {busy:.0%} busy with these"


#: A participant's vote latency the capacity figure holds to (p99, steady state).
CAPACITY_P99_MS = 200.0


@dataclass
class OpenRun:
    """What one open-loop run measured: its participants, the steady state's vote p99 (ms) and
    the CPU per trial of the server and of its PostgreSQL backends (ms)."""

    participants: int
    vote_p99: float | None
    server_ms: float
    postgres_ms: float


def run_open(
    args: argparse.Namespace,
    participants: int,
    slug: str,
    acknowledged: dict[int, str],
    meter: CpuMeter,
) -> OpenRun:
    rate = args.arrival_rate or participants / 10
    before = meter.read()
    wall = time.perf_counter()
    tally, elapsed = asyncio.run(
        load_clients.open_loop(
            f"http://127.0.0.1:{args.port}",
            slug,
            participants,
            rate=rate,
            think=args.think,
            trials=args.trials,
            timeout=args.timeout,
            seed=participants,
        )
    )
    after = meter.read()
    acknowledged.update(tally.acknowledged)
    votes = len(tally.ms.get("vote", []))
    print(
        f"open loop: {participants} participants arriving at {rate:.3g}/s, {args.trials} "
        f"trials each, {args.think:g} s clip; peak {tally.peak} present at once, "
        f"{tally.finished} finished, {elapsed:.1f} s, {votes / elapsed:.0f} vote requests/s "
        f"(load {os.getloadavg()[0]:.1f})"
    )
    for kind in ("vote", "play", "page", "consent"):
        print(f"  {kind:8s} {tally.summary(kind)}")
    # The steady state: requests sent while nearly every participant was present at once.
    print(
        f"  while >= {STEADY:.0%} of the peak were present ({tally.window(STEADY):.0f} s): "
        + "; ".join(f"{kind} {tally.summary(kind, STEADY)}" for kind in ("vote", "play"))
    )
    print(
        f"  errors {len(tally.errors)}, statuses {dict(sorted(tally.statuses.items()))}, "
        f"answered with an earlier vote's other choice {tally.superseded}"
    )
    trials = max(len(tally.ms.get("play", [])), 1)  # one play per trial
    print(cpu_line(before, after, trials, "trial", time.perf_counter() - wall))
    for e in tally.errors[:5]:
        print("  error:", e)
    used = cpu_used(before, after)
    return OpenRun(
        participants,
        tally.p99("vote", STEADY),
        used["server"] / trials * 1e3,
        used["postgres"] / trials * 1e3,
    )


def capacity_lines(runs: list[OpenRun], think: float, cores: int) -> list[str]:
    """The capacity figures of the open-loop runs: CPU per trial (server + its PostgreSQL
    backends), the participants that CPU would let two cores serve at one vote per ``think``
    seconds, and the largest count run whose steady-state vote p99 stayed under
    :data:`CAPACITY_P99_MS`."""
    lines = []
    for run in runs:
        total = run.server_ms + run.postgres_ms
        bound = cores * think * 1e3 / total if total > 0 else float("inf")
        p99 = "none" if run.vote_p99 is None else f"{run.vote_p99:.0f} ms"
        lines.append(
            f"capacity at {run.participants}: CPU per trial {total:.1f} ms (server "
            f"{run.server_ms:.1f} + PostgreSQL {run.postgres_ms:.1f}), so {cores} cores "
            f"would be saturated at about {bound:.0f} participants voting every {think:g} s; "
            f"steady vote p99 {p99}"
        )
    kept = [r.participants for r in runs if r.vote_p99 is not None and r.vote_p99 < CAPACITY_P99_MS]
    lines.append(
        f"largest count run with steady vote p99 < {CAPACITY_P99_MS:.0f} ms: "
        + (f"{max(kept)}" if kept else "none")
        + f" (of {', '.join(str(r.participants) for r in runs)})"
    )
    return lines


def trials_of(url: str, tokens: list[str]) -> list[tuple[str, int]]:
    """(token, trial id) of the participants' real and catch trials, position by position
    and participant by participant: round robin over them, as in a study, concurrent votes
    come from different people, never 64 at once on one participant's row."""
    import psycopg

    with psycopg.connect(url.replace("postgresql+psycopg://", "postgresql://")) as conn:
        return conn.execute(
            "SELECT p.token, t.id FROM trial t JOIN participant p ON p.id = t.participant_id "
            "WHERE p.token = ANY(%s) AND t.kind <> 'practice' ORDER BY t.position, p.id",
            (tokens,),
        ).fetchall()


def saturated_votes(
    args: argparse.Namespace,
    slug: str,
    url: str,
    acknowledged: dict[int, str],
    meter: CpuMeter,
    participants: int,
    label: str,
) -> float:
    """facepair's vote endpoint driven saturated by the votes of ``participants`` freshly
    consented participants (18 each); returns votes per second."""
    base = f"http://127.0.0.1:{args.port}"
    tokens = asyncio.run(load_clients.consent_many(base, slug, participants, timeout=args.timeout))
    rows = trials_of(url, tokens)
    rng = np.random.default_rng(1)
    bodies = []
    for token, trial in rows:
        choice = str(rng.choice(["left", "right", "undecided"]))
        bodies.append(
            (
                trial,
                choice,
                load_clients.vote_body(token, trial, choice, secrets.token_hex(8), 1500),
            )
        )
    return _drive(f"{base}/api/v1/votes", bodies, label, args, acknowledged, meter)


def _drive(
    url: str,
    bodies: list[tuple[int, str, bytes]],
    name: str,
    args: argparse.Namespace,
    acknowledged: dict[int, str],
    meter: CpuMeter,
) -> float:
    before = meter.read()
    wall = time.perf_counter()
    tally, elapsed = asyncio.run(
        load_clients.saturate(url, bodies, concurrency=64, timeout=args.timeout)
    )
    after = meter.read()
    acknowledged.update(tally.acknowledged)
    rate = len(tally.acknowledged) / elapsed
    print(
        f"saturated, {name}: {len(tally.acknowledged)} of {len(bodies)} votes stored in "
        f"{elapsed:.1f} s by 64 senders, {rate:.0f} votes/s; vote {tally.summary('vote')}; "
        f"errors {len(tally.errors)} (load {os.getloadavg()[0]:.1f})"
    )
    print(cpu_line(before, after, len(bodies), "vote", time.perf_counter() - wall))
    return rate


def round_size(rate: float, seconds: float, least: int) -> int:
    """How many votes keep a round saturated for ``seconds`` at ``rate`` votes/s (the fastest
    seen so far; a warm-up runs slower than the rounds after it, so half as many again), and
    at least ``least``."""
    return max(least, int(np.ceil(1.5 * rate * seconds)))


def start_bare_baseline(args: argparse.Namespace, url: str, media: Path) -> subprocess.Popen[bytes]:
    """The bare baseline's server, on the port after facepair's, on the same database."""
    dsn = url.replace("postgresql+psycopg://", "postgresql://")
    port = args.port + 1
    return start_server(
        [
            str(ROOT / "benchmarks" / "bare_baseline.py"),
            "--dsn",
            dsn,
            "--port",
            str(port),
            "--workers",
            str(args.workers),
        ],
        dict(os.environ),
        port,
        media / "baseline.log",
    )


def bare_baseline(args: argparse.Namespace, votes: int, meter: CpuMeter, label: str) -> float:
    """The bare baseline driven like facepair's vote endpoint; returns votes per second."""
    bodies = [
        (
            i,
            "left",
            json.dumps(
                {
                    "token": secrets.token_hex(11),
                    "trial_id": i,
                    "choice": "left",
                    "idempotency_key": secrets.token_hex(8),
                }
            ).encode(),
        )
        for i in range(votes)
    ]
    url = f"http://127.0.0.1:{args.port + 1}/votes"
    return _drive(url, bodies, label, args, {}, meter)


def saturated_rounds(
    args: argparse.Namespace,
    slug: str,
    url: str,
    acknowledged: dict[int, str],
    meter: CpuMeter,
    database: str,
    media: Path,
) -> tuple[list[float], list[float]]:
    """facepair's vote endpoint saturated, alternating with the bare baseline (``--baseline``),
    each after an untimed warm-up round (its workers compile and prepare their statements),
    in rounds sized from the warm-up to last at least ``--round-seconds``; returns the counted
    rounds' votes per second, facepair's and the baseline's."""
    least = args.saturate * 18
    fastest = saturated_votes(
        args, slug, url, acknowledged, meter, args.saturate, "facepair warm-up"
    )
    bare_server, bare_meter, bare_fastest = None, None, 0.0
    if args.baseline:
        bare_server = start_bare_baseline(args, url, media)
        bare_meter = CpuMeter(bare_server.pid, meter.admin, database)
        bare_fastest = bare_baseline(args, least, bare_meter, "bare baseline warm-up")
    # The two alternate, so both meet the machine in the same state (the database's
    # background writing after the open loop, other work on the host). Each round is sized
    # from the fastest rate seen before it.
    facepair: list[float] = []
    bare: list[float] = []
    try:
        for index in range(args.rounds):
            label = f"round {index + 1}"
            people = int(np.ceil(round_size(fastest, args.round_seconds, least) / 18))
            facepair.append(
                saturated_votes(args, slug, url, acknowledged, meter, people, f"facepair {label}")
            )
            fastest = max(fastest, facepair[-1])
            if bare_meter is not None:
                votes = round_size(bare_fastest, args.round_seconds, least)
                bare.append(bare_baseline(args, votes, bare_meter, f"bare baseline {label}"))
                bare_fastest = max(bare_fastest, bare[-1])
    finally:
        if bare_server is not None:
            stop_server(bare_server)
    return facepair, bare


def participant_counts(text: str) -> list[int]:
    """``"200,500,1000"`` -> ``[200, 500, 1000]``; ValueError naming the option otherwise."""
    try:
        counts = [int(n) for n in text.split(",")]
    except ValueError:
        counts = []
    if not counts or not all(0 < n <= 100_000 for n in counts):
        raise ValueError(
            f"--participants: expected counts from 1 to 100000 such as 200,500,1000, not {text!r}"
        )
    return counts


def check_ready(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Stop, in one line, a run of no rounds or no participants, or one without PostgreSQL
    (shared with ``bench_ab.py``)."""
    if args.rounds < 1 or args.saturate < 1:
        parser.error("--rounds and --saturate: expected a whole number of at least 1")
    if not ensure_services(redis=False):
        sys.exit("PostgreSQL is not reachable on 127.0.0.1:5432")


def unlimited_instance(folder: Path) -> Path:
    """An instance folder whose config lifts the consent limits: the load generator is one
    address standing for every participant, which the per-address limit exists to stop."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "config.py").write_text(
        'CONSENT_LIMIT_PER_ADDRESS = ""\nCONSENT_LIMIT_PER_STUDY = ""\n', encoding="utf-8"
    )
    return folder


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mode", choices=("open", "closed"), default="open")
    parser.add_argument(
        "--participants",
        default="200",
        help="comma-separated counts, one run each (open: 200,500,1000)",
    )
    parser.add_argument(
        "--think",
        type=float,
        default=6.0,
        help="seconds each clip is watched before the vote (open loop)",
    )
    parser.add_argument("--trials", type=int, default=6, help="votes per participant (open)")
    parser.add_argument(
        "--arrival-rate",
        type=float,
        default=0.0,
        help="arrivals per second (open; default: all within 10 s)",
    )
    parser.add_argument("--timeout", type=float, default=30.0, help="seconds per request")
    parser.add_argument(
        "--saturate",
        type=int,
        default=120,
        help="participants whose votes drive the saturated run (open)",
    )
    parser.add_argument(
        "--baseline", action="store_true", help="also drive the bare baseline and print the ratio"
    )
    parser.add_argument(
        "--rounds",
        type=int,
        default=3,
        help="saturated runs of each, facepair and the baseline alternating (open)",
    )
    parser.add_argument(
        "--round-seconds",
        type=float,
        default=10.0,
        help="least length of a counted saturated round; an untimed warm-up round runs first",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=2,
        help="gunicorn worker processes (2, facepair serve's default; 4 threads each)",
    )
    parser.add_argument("--port", type=int, default=5077)
    parser.add_argument(
        "--pg",
        default=PG,
        help="libpq connection string of the PostgreSQL server to create the database on "
        "(default: FACEPAIR_BENCH_PG, else the tests' server)",
    )
    parser.add_argument(
        "--redis-url",
        default=os.environ.get("FACEPAIR_BENCH_REDIS_URL", ""),
        help="REDIS_URL for the server (its rate limits' counters); default none, in memory",
    )
    parser.add_argument(
        "--keep",
        action="store_true",
        help="keep the database and its media folder (with the servers' logs) afterwards",
    )
    args = parser.parse_args()
    try:
        counts = participant_counts(args.participants)
    except ValueError as exc:
        parser.error(str(exc))
    check_ready(parser, args)
    import psycopg

    name = f"facepair_load_{secrets.token_hex(3)}"
    url = database_url(args.pg, name)
    admin = psycopg.connect(f"{args.pg} dbname=postgres", autocommit=True)
    admin.execute(f'CREATE DATABASE "{name}"')
    media = Path(os.environ.get("TMPDIR", "/tmp")) / name
    server = None
    print(f"load average before: {open('/proc/loadavg').read().strip()}")
    try:
        slug = prepare(url, media)
        env = {
            **os.environ,
            "DATABASE_URL": url,
            "MEDIA_ROOT": str(media),
            "SECRET_KEY": secrets.token_hex(16),
            "FACEPAIR_INSTANCE": str(unlimited_instance(media / "instance")),
        }
        env.pop("REDIS_URL", None)
        if args.redis_url:
            env["REDIS_URL"] = args.redis_url
        server = start_server(
            ["-m", "app", "serve", "--port", str(args.port), "--workers", str(args.workers)],
            env,
            args.port,
            media / "server.log",
        )
        if args.mode == "closed":
            return 0 if all(run_closed(args, n, slug, url) for n in counts) else 1
        meter = CpuMeter(server.pid, admin, name)
        acknowledged: dict[int, str] = {}
        runs = [run_open(args, n, slug, acknowledged, meter) for n in counts]
        for line in capacity_lines(runs, args.think, os.cpu_count() or 1):
            print(line)
        facepair, bare = saturated_rounds(args, slug, url, acknowledged, meter, name, media)
        stop_server(server)
        server = None
        line, stored_ok = check(url, acknowledged)
        print(line)
        if args.baseline:
            ours, theirs = float(np.median(facepair)), float(np.median(bare))
            print(
                f"facepair's saturated vote throughput (median of {args.rounds} rounds "
                f"alternating with the baseline, warm-ups not counted): {ours:.0f}/s = "
                f"{ours / theirs:.0%} of the bare baseline's {theirs:.0f}/s"
            )
        print(f"load average after: {open('/proc/loadavg').read().strip()}")
        # Client errors (timeouts of an overloaded server) are reported above; the exit
        # status is about the votes: none lost, none duplicated.
        return 0 if stored_ok else 1
    finally:
        if server is not None:
            stop_server(server)
        if not args.keep:
            admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
            if sys.exc_info()[0] is None:  # a failed run keeps its servers' logs
                shutil.rmtree(media, ignore_errors=True)
        admin.close()


if __name__ == "__main__":
    sys.exit(main())
