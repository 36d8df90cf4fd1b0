"""Load benchmark: 200 simulated participants voting at once against gunicorn + PostgreSQL.

Creates a fresh PostgreSQL database on 127.0.0.1:5432 (user postgres), migrates it, creates the
example study (app/data/examples: 4 conditions, all ordered pairs, 2 catch trials = 18 trials
per participant) with placeholder clips, and starts ``facepair serve`` (gunicorn, gthread) on it.
Then every simulated participant, each in its own thread with its own keep-alive connection,
does what the browser does: opens the study link, consents (CSRF form), and for each trial
loads the trial page and posts its vote to ``/api/v1/votes``; one vote in ten is posted twice
(a retried request with the same idempotency key) and one in twenty a third time with a new key
(a double click). Afterwards the votes are counted in the database: every trial must hold
exactly one vote - none lost, none duplicated.

Prints vote requests per second over the voting phase, p50/p90/p99 latency of vote requests and
of trial pages, and the database counts. Exits 1 if any vote is lost or duplicated.

    python benchmarks/bench_load.py [--participants 200] [--workers 4] [--port 5077]
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import re
import secrets
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from urllib.parse import urlencode

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
PG = "host=127.0.0.1 port=5432 user=postgres"


def ensure_postgres() -> None:
    """Start the local PostgreSQL cluster if it is down."""
    if _port_open(5432):
        return
    version = sorted(p.name for p in Path("/etc/postgresql").iterdir())[-1]
    subprocess.run(["pg_ctlcluster", "--skip-systemctl-redirect", version, "main", "start"],
                   check=False)
    for _ in range(100):
        if _port_open(5432):
            return
        time.sleep(0.1)
    sys.exit("PostgreSQL is not reachable on 127.0.0.1:5432")


def _port_open(port: int) -> bool:
    with socket.socket() as sock:
        sock.settimeout(0.5)
        return sock.connect_ex(("127.0.0.1", port)) == 0


def prepare(url: str, media: Path) -> str:
    """Migrate the database, create the example study, open it; returns its slug."""
    import sqlalchemy as sa
    from flask_migrate import upgrade

    from app import create_app
    from app.experimenter.auth import create_user
    from app.extensions import db
    from app.models import Stimulus
    from app.storage import media_dir
    from app.studies import create_study
    from app.trials.studyfile import loads_study

    app = create_app({"SQLALCHEMY_DATABASE_URI": url, "MEDIA_ROOT": str(media),
                      "JOB_RUNNER": "inline", "REQUIRE_SECRET_KEY": False})
    with app.app_context():
        upgrade()
        owner = create_user("load@example.org", "load benchmark")
        db.session.commit()
        study_file = ROOT / "app" / "data" / "examples" / "study.toml"
        text = study_file.read_text(encoding="utf-8")
        study = create_study(owner, loads_study(text, base_dir=study_file.parent),
                             source_toml=text)
        folder = media_dir(study) / "videos"
        folder.mkdir(parents=True, exist_ok=True)
        for stimulus in db.session.scalars(sa.select(Stimulus)
                                           .where(Stimulus.study_id == study.id)):
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

    def request(self, method: str, path: str, body: bytes | None = None,
                headers: dict[str, str] | None = None) -> tuple[int, dict[str, str], bytes]:
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
            "POST", f"/s/{self.slug}{query}", form,
            {"Content-Type": "application/x-www-form-urlencoded"})
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
            repeats = [key] + ([key] if rng.random() < 0.1 else []) + (
                [secrets.token_hex(8)] if rng.random() < 0.05 else [])
            for k in repeats:
                body = json.dumps({"token": who, "trial_id": trial, "choice": choice,
                                   "plays": 1, "watched_to_end": True,
                                   "response_ms": int(rng.integers(800, 4000)),
                                   "idempotency_key": k}).encode()
                start = time.perf_counter()
                status, _, _ = self.request("POST", "/api/v1/votes", body,
                                            {"Content-Type": "application/json"})
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
            "unanswered": one("SELECT count(*) FROM trial t WHERE t.kind <> 'practice' AND "
                              "NOT EXISTS (SELECT 1 FROM vote v WHERE v.trial_id = t.id)"
                              ).fetchone()[0],
            "duplicated": one("SELECT count(*) FROM (SELECT trial_id FROM vote GROUP BY "
                              "trial_id HAVING count(*) > 1) d").fetchone()[0],
        }


def stored_choices(url: str) -> dict[int, str]:
    import psycopg

    dsn = url.replace("postgresql+psycopg://", "postgresql://")
    with psycopg.connect(dsn) as conn:
        return dict(conn.execute("SELECT trial_id, choice FROM vote").fetchall())


def _pct(values: list[float]) -> str:
    v = np.asarray(values)
    return (f"p50 {np.percentile(v, 50):.1f} ms, p90 {np.percentile(v, 90):.1f} ms, "
            f"p99 {np.percentile(v, 99):.1f} ms, max {v.max():.1f} ms")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--participants", type=int, default=200)
    parser.add_argument("--workers", type=int, default=4, help="gunicorn worker processes")
    parser.add_argument("--port", type=int, default=5077)
    parser.add_argument("--keep", action="store_true", help="keep the database afterwards")
    args = parser.parse_args()
    ensure_postgres()
    import psycopg

    name = f"facepair_load_{secrets.token_hex(3)}"
    url = f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}"
    admin = psycopg.connect(f"{PG} dbname=postgres", autocommit=True)
    admin.execute(f'CREATE DATABASE "{name}"')
    media = Path(os.environ.get("TMPDIR", "/tmp")) / name
    server = None
    try:
        slug = prepare(url, media)
        env = {**os.environ, "DATABASE_URL": url, "MEDIA_ROOT": str(media),
               "SECRET_KEY": secrets.token_hex(16)}
        log = open(media / "server.log", "wb")  # noqa: SIM115 (closed below)
        server = subprocess.Popen([sys.executable, "-m", "app", "serve", "--port",
                                   str(args.port), "--workers", str(args.workers)],
                                  env=env, stdout=log, stderr=subprocess.STDOUT, cwd=ROOT)
        for _ in range(300):
            if _port_open(args.port):
                break
            time.sleep(0.1)
        else:
            sys.exit("the server did not start; see " + str(media / "server.log"))
        gate = threading.Barrier(args.participants + 1)
        people = [Participant(args.port, slug, gate) for _ in range(args.participants)]
        for p in people:
            p.start()
        gate.wait()
        start = time.perf_counter()
        for p in people:
            p.join()
        elapsed = time.perf_counter() - start
        errors = [p.error for p in people if p.error]
        counts = count(url)
        stored = stored_choices(url)
        clicked = {trial: choice for p in people for trial, choice in p.votes}
        vote_ms = [ms for p in people for ms in p.vote_ms]
        page_ms = [ms for p in people for ms in p.page_ms]
        statuses: dict[int, int] = {}
        for p in people:
            for code, n in p.statuses.items():
                statuses[code] = statuses.get(code, 0) + n
        print(f"{args.participants} participants at once, gunicorn {args.workers} workers x 4 "
              f"threads, PostgreSQL, {elapsed:.1f} s from first consent to last vote")
        print(f"vote requests: {len(vote_ms)} ({statuses.get(201, 0)} stored, "
              f"{statuses.get(200, 0)} repeats answered 'already stored'), "
              f"{len(vote_ms) / elapsed:.0f} per s; {_pct(vote_ms)}")
        print(f"trial pages: {len(page_ms)}, {_pct(page_ms)}")
        lost = counts["unanswered"]
        wrong = sum(1 for t, c in clicked.items() if stored.get(t) != c)
        print(f"database: {counts['participants']} participants, {counts['trials']} trials, "
              f"{counts['votes']} votes; lost {lost}, duplicated {counts['duplicated']}, "
              f"differing from the click {wrong}; client errors {len(errors)}")
        for e in errors[:5]:
            print("  error:", e)
        ok = not errors and lost == 0 and counts["duplicated"] == 0 and wrong == 0 \
            and counts["votes"] == len(clicked)
        return 0 if ok else 1
    finally:
        if server is not None:
            server.terminate()
            server.wait(timeout=30)
        if not args.keep:
            admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
        admin.close()


if __name__ == "__main__":
    sys.exit(main())
