"""Fault checks: a study taken by simulated participants while the platform is hurt.

Starts a private PostgreSQL cluster and a private Redis (127.0.0.1, free ports, in a temporary
folder), migrates the database, creates two studies (the example study for voting, with
placeholder clips; a small three-condition study to render) and starts ``facepair serve``
(gunicorn) and ``facepair worker`` (RQ) on them. Then, while every simulated participant does
what the browser does (consent, then trial page and vote until done; a vote is resent with the
same idempotency key after a network error or a 5xx, honouring Retry-After, never after a
4xx), and an experimenter generates and renders the second study from the web, it injects:

* SIGKILLs of gunicorn workers (``--worker-kills``, spread over the run);
* a database restart (PostgreSQL stopped for ``--db-down`` seconds, then started);
* a Redis outage (stopped for ``--redis-down`` seconds) during which another experimenter logs
  in and asks for a report job (it must be refused with a message, leaving no row);
* render-job kills: the work horse running the render is SIGKILLed mid-job; after the retry
  the whole worker is SIGKILLed and restarted. Each killed job must end ``failed`` with its
  reason; its retry must resume from the clips already rendered.

It prints votes acknowledged / stored / lost / duplicated, responses >= 500 by cause, network
errors, each job's fate, and jobs left queued or running ("stuck"); it exits 1 on any lost or
duplicated vote, a stored choice other than the click, a stuck job, or a job kill not ending
in a resumed render. Not part of the test suite (too slow); ``tests/test_chaos.py`` runs a
slice of it (one worker kill, one job kill) on the test services.

    python benchmarks/chaos.py [--participants 30] [--workers 3] [--worker-kills 6] [--keep DIR]
"""

from __future__ import annotations

import argparse
import re
import secrets
import sys
import tempfile
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.chaos_clients import Browser, Experimenter, Participant, Tally
from benchmarks.chaos_services import (
    ROOT,
    JobWorker,
    PrivatePostgres,
    PrivateRedis,
    Site,
    environment,
)

RENDER_STUDY = """
title = "Chaos render"
question = "Which face moves more naturally?"
design = "all_ordered"
practice = false

[render]
size = 64
mosaic_block = 8

[[conditions]]
name = "still"
model = "none"

[[conditions]]
name = "noise"
model = "random"

[[conditions]]
name = "speech"
model = "speech_driven"

[[clips]]
name = "s1"
audio = "{audio}"
"""
EXPERIMENTER = ("chaos@example.org", "chaos experimenter orchid tundra")


@dataclass
class Options:
    participants: int = 30
    web_workers: int = 3
    worker_kills: int = 6
    #: Seconds PostgreSQL / Redis stay down; 0: no such fault.
    db_down: float = 4.0
    redis_down: float = 8.0
    #: "horse" (the process running the job) and/or "worker" (the whole worker, restarted).
    job_kills: tuple[str, ...] = ("horse", "worker")
    think: tuple[float, float] = (0.8, 1.6)
    stale_after: int = 6
    #: Seconds over which the participants arrive and the faults are spread.
    span: float = 40.0


@dataclass
class Result:
    acknowledged: int = 0
    stored: int = 0
    lost: int = 0
    duplicated: int = 0
    wrong: int = 0
    stuck: int = 0
    tally: Tally = field(default_factory=Tally)
    jobs: list[str] = field(default_factory=list)
    kills: list[tuple[str, str]] = field(default_factory=list)
    resumed: bool = False
    faults: Counter[str] = field(default_factory=Counter)
    outage: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not (self.lost or self.duplicated or self.wrong or self.stuck) and self.resumed


def prepare(database_url: str, media: Path, folder: Path) -> tuple[str, int, int]:
    """Migrate, add the experimenter and both studies; returns (voting slug, its id, the
    render study's id)."""
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
            "SQLALCHEMY_DATABASE_URI": database_url,
            "MEDIA_ROOT": str(media),
            "JOB_RUNNER": "inline",
            "REQUIRE_SECRET_KEY": False,
        }
    )
    with app.app_context():
        upgrade()
        owner = create_user(*EXPERIMENTER)
        db.session.commit()
        example = ROOT / "app" / "data" / "examples" / "study.toml"
        text = example.read_text(encoding="utf-8")
        voting = create_study(owner, loads_study(text, base_dir=example.parent), source_toml=text)
        for stimulus in db.session.scalars(
            sa.select(Stimulus).where(Stimulus.study_id == voting.id)
        ):
            path = media_dir(voting) / "videos" / f"{stimulus.id}.mp4"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(b"\0" * 1024)  # never played here
            stimulus.video_path = f"videos/{stimulus.id}.mp4"
        voting.status, voting.target_participants = "open", 10_000
        text = RENDER_STUDY.format(audio=ROOT / "app" / "data" / "demo" / "speech.wav")
        rendered = create_study(owner, loads_study(text, base_dir=folder), source_toml=text)
        db.session.commit()
        ids = voting.slug, voting.id, rendered.id
        db.session.remove()
        db.engine.dispose()
    return ids


def count_votes(
    database_url: str, study_id: int, acknowledged: dict[int, str]
) -> tuple[int, int, int, int]:
    """(stored, lost, duplicated, wrong): votes of the study's participants against the
    acknowledged clicks (trial id -> choice)."""
    import sqlalchemy as sa

    engine = sa.create_engine(database_url)
    with engine.connect() as conn:
        rows = conn.execute(
            sa.text(
                "SELECT v.trial_id, v.choice FROM vote v JOIN participant p ON p.id = "
                "v.participant_id WHERE p.study_id = :study"
            ),
            {"study": study_id},
        ).all()
    engine.dispose()
    stored: dict[int, list[str]] = {}
    for trial_id, choice in rows:
        stored.setdefault(trial_id, []).append(choice)
    lost = sum(trial not in stored for trial in acknowledged)
    duplicated = sum(len(choices) - 1 for choices in stored.values())
    wrong = sum(
        trial in stored and stored[trial][0] != choice for trial, choice in acknowledged.items()
    )
    return len(rows), lost, duplicated, wrong


def stuck_jobs(database_url: str) -> int:
    import sqlalchemy as sa

    engine = sa.create_engine(database_url)
    with engine.connect() as conn:
        found = conn.execute(
            sa.text("SELECT count(*) FROM job WHERE status IN ('queued', 'running')")
        ).scalar_one()
    engine.dispose()
    return int(found)


class Injector(threading.Thread):
    """Runs the faults on a timeline; restarts the job worker if it dies on its own (as a
    process supervisor would)."""

    def __init__(
        self,
        options: Options,
        site: Site,
        worker: JobWorker,
        postgres: PrivatePostgres | None,
        redis: PrivateRedis | None,
        port: int,
        study_id: int,
        result: Result,
    ) -> None:
        super().__init__(daemon=True)
        self.options, self.site, self.worker = options, site, worker
        self.postgres, self.redis, self.port = postgres, redis, port
        self.study_id, self.result = study_id, result
        self.done = threading.Event()

    def timeline(self) -> list[tuple[float, str]]:
        span, kills = self.options.span, self.options.worker_kills
        events = [(span * (k + 0.5) / max(kills, 1), "web-worker") for k in range(kills)]
        if self.options.db_down and self.postgres is not None:
            events.append((span * 0.45, "database"))
        if self.options.redis_down and self.redis is not None:
            events.append((span * 0.75, "redis"))
        return sorted(events)

    def run(self) -> None:
        start = time.monotonic()
        pending = self.timeline()
        while not self.done.is_set():
            if self.worker.restart_if_exited():  # as a process supervisor would
                self.result.faults["job worker restarted after exiting"] += 1
            if pending and time.monotonic() - start >= pending[0][0]:
                fault = pending.pop(0)[1]
                getattr(self, "fault_" + fault.replace("-", "_"))()
                self.result.faults[fault] += 1
            time.sleep(0.1)

    def fault_web_worker(self) -> None:
        workers = self.site.workers()
        if workers:
            import os
            import signal

            os.kill(secrets.choice(workers), signal.SIGKILL)

    def fault_database(self) -> None:
        assert self.postgres is not None
        self.postgres.stop()
        time.sleep(self.options.db_down)
        self.postgres.start()

    def fault_redis(self) -> None:
        assert self.redis is not None
        self.redis.stop()
        try:
            time.sleep(1.0)
            # Another experimenter logs in and asks for a report while the queue is away.
            with Browser(self.port, Tally()) as probe:
                status = probe.login(*EXPERIMENTER)
                before = probe.job_ids(self.study_id)
                page = probe.start_job(self.study_id, "report")
                orphans = len(probe.job_ids(self.study_id) - before)
            refused = re.search(r"The report job could not be started: [^<]*", page)
            self.result.outage.append(
                f"login answered {status}; report job: "
                f"{refused.group(0)[:90] + '...' if refused else 'NOT REFUSED'}; "
                f"rows left behind: {orphans}"
            )
            time.sleep(max(0.0, self.options.redis_down - 1.0))
        finally:
            self.redis.start()


def run(
    options: Options,
    folder: Path,
    *,
    database_url: str | None = None,
    redis_url: str | None = None,
    echo=print,
) -> Result:  # type: ignore[no-untyped-def]
    """The whole check; private PostgreSQL and Redis unless URLs are given (then the
    database must be empty and the faults needing a private server are skipped)."""
    postgres = redis = None
    if database_url is None:
        postgres = PrivatePostgres(folder)
        postgres.create()
        database_url = postgres.url
    if redis_url is None:
        redis = PrivateRedis(folder / "redis")
        redis.start()
        redis_url = redis.url
    media, result = folder / "media", Result()
    site = worker = injector = None
    try:
        slug, voting_id, render_id = prepare(database_url, media, folder)
        env = environment(database_url, redis_url, media, folder / "instance", options.stale_after)
        site = Site(env, folder / "gunicorn.log", options.web_workers)
        worker = JobWorker(env, folder / "worker.log")
        # Paint the built-in head's texture once, as an install would: a job whose process
        # paints it stays silent for seconds, longer than this run's short stale limit.
        from renderer.headmodel import builtin_face

        builtin_face()
        site.start()
        worker.start()
        echo(
            f"chaos: {options.participants} participants, gunicorn {options.web_workers} "
            f"workers x 4 threads on :{site.port}, PostgreSQL "
            f"{'private' if postgres else database_url.rsplit('@', 1)[-1]}, Redis "
            f"{'private' if redis else redis_url}"
        )
        people = [
            Participant(
                site.port,
                slug,
                result.tally,
                options.think,
                delay=options.span * 0.4 * k / max(options.participants, 1),
            )
            for k in range(options.participants)
        ]
        experimenter = Experimenter(
            site.port, render_id, worker, options.job_kills, EXPERIMENTER, result
        )
        injector = Injector(options, site, worker, postgres, redis, site.port, render_id, result)
        for thread in (*people, experimenter, injector):
            thread.start()
        for thread in (*people, experimenter):
            thread.join()
        injector.done.set()
        injector.join()
        experimenter.sweep()  # what the study page does: a dead job never shows as running
        acknowledged = {trial: choice for p in people for trial, choice in p.acknowledged}
        result.acknowledged = len(acknowledged)
        result.stored, result.lost, result.duplicated, result.wrong = count_votes(
            database_url, voting_id, acknowledged
        )
        result.stuck = stuck_jobs(database_url)
        for person in people:
            if person.error:
                result.tally.failures[person.error] += 1
    finally:
        if injector is not None:  # it must not restart the worker stopped below
            injector.done.set()
            injector.join()
        for process in (site, worker):
            if process is not None:
                process.stop()
        if redis is not None:
            redis.stop()
        if postgres is not None:
            postgres.stop()
    return result


def report(result: Result, echo=print) -> None:  # type: ignore[no-untyped-def]
    tally = result.tally
    echo(f"faults: {dict(result.faults)}; job kills: {[k for k, _ in result.kills]}")
    echo(
        f"votes acknowledged {result.acknowledged} / stored {result.stored} / lost "
        f"{result.lost} / duplicated {result.duplicated} / stored choice differs "
        f"{result.wrong}"
    )
    echo(f"responses >= 500: {sum(tally.server_errors.values())}")
    for cause, n in tally.server_errors.most_common():
        echo(f"  {n:5d}  {cause}")
    echo(
        f"network errors (connection refused or reset): {tally.network_errors}; "
        f"requests resent: {tally.resent}; 4xx on a vote: {dict(tally.refused)}"
    )
    for kill, message in result.kills:
        echo(f"job kill ({kill}): row ended failed: {message}")
    for line in result.jobs:
        echo(f"job: {line}")
    for line in result.outage:
        echo(f"redis outage: {line}")
    for failure, n in tally.failures.items():
        echo(f"participant gave up ({n}): {failure}")
    echo(
        f"jobs stuck queued or running: {result.stuck}; render resumed after kills: "
        f"{'yes' if result.resumed else 'NO'}"
    )
    echo("result: " + ("OK" if result.ok else "FAILED"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--participants", type=int, default=30)
    parser.add_argument("--workers", type=int, default=3, help="gunicorn workers")
    parser.add_argument("--worker-kills", type=int, default=6)
    parser.add_argument("--db-down", type=float, default=4.0)
    parser.add_argument("--redis-down", type=float, default=8.0)
    parser.add_argument("--span", type=float, default=40.0)
    parser.add_argument("--keep", type=Path, help="work in this folder and keep it (logs)")
    args = parser.parse_args()
    options = Options(
        participants=args.participants,
        web_workers=args.workers,
        worker_kills=args.worker_kills,
        db_down=args.db_down,
        redis_down=args.redis_down,
        span=args.span,
    )
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=False)
        result = run(options, args.keep.resolve())
    else:
        with tempfile.TemporaryDirectory(prefix="facepair-chaos-") as tmp:
            result = run(options, Path(tmp))
    report(result)
    sys.exit(0 if result.ok else 1)


if __name__ == "__main__":
    main()
