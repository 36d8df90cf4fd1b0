"""Benchmark: what a consent costs as a study grows, with and without the active-participants index.

A consent enrols one participant (``app.web.study.enrolment.enrol``: the release of idle
participants, a list slot, the schedule's trials) and commits. Measured on PostgreSQL in one
process, for a study holding 0 and ``--size`` earlier participants (finished ones, as in a study
that ran for a while), in alternating blocks:

- facepair: the schema as migrated (the partial index ``ix_participant_active``);
- comparator: the same database with that index dropped, i.e. the release scanning the study's
  participant table as it did before.

Printed: the median consent (ms) for each, the plan of the release's query, and the ratio of
the large study's consent to the empty one's (the goal: about 1, independent of the size).

    PYTHONPATH=$PWD python benchmarks/bench_consent.py               # 50,000 earlier participants
    PYTHONPATH=$PWD python benchmarks/bench_consent.py --size 5000   # quicker

The database (``facepair_bench_consent_<pid>``) is created on FACEPAIR_TEST_PG_HOST/PORT
(default 127.0.0.1:5432) and dropped at the end.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import secrets
import statistics
import sys
import tempfile
import time
from pathlib import Path

import psycopg
import sqlalchemy as sa

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

HOST = os.environ.get("FACEPAIR_TEST_PG_HOST", "127.0.0.1")
PORT = int(os.environ.get("FACEPAIR_TEST_PG_PORT", "5432"))


def _admin(sql: str) -> None:
    with psycopg.connect(f"host={HOST} port={PORT} user=postgres dbname=postgres") as conn:
        conn.autocommit = True
        conn.execute(sql)


def _app(url: str, media: Path):  # type: ignore[no-untyped-def]
    from flask_migrate import upgrade

    from app.web import create_app

    app = create_app(
        {
            "TESTING": True,
            "SECRET_KEY": secrets.token_hex(32),
            "SQLALCHEMY_DATABASE_URI": url,
            "MEDIA_ROOT": str(media),
        }
    )
    with app.app_context():
        upgrade()
    return app


def _study(app, folder: Path) -> int:  # type: ignore[no-untyped-def]
    from app.trials.studyfile import load_study_file
    from app.web.extensions import db
    from app.web.infra.accounts import create_user
    from app.web.models import User
    from app.web.study.studies import create_study

    with app.app_context():
        owner = db.session.scalar(sa.select(User)) or create_user(
            "bench@example.org", "correct horse battery"
        )
        db.session.flush()
        spec = load_study_file(REPO / "app" / "data" / "examples" / "study.toml")
        study = create_study(owner, spec)
        db.session.commit()
        return study.id


def _fill(app, study_id: int, n: int) -> None:  # type: ignore[no-untyped-def]
    """``n`` earlier participants who finished long ago (rows only: no trials needed)."""
    from app.web.extensions import db
    from app.web.models import Participant, StudyList

    with app.app_context():
        list_id = db.session.scalar(sa.select(StudyList.id).where(StudyList.study_id == study_id))
        long_ago = dt.datetime(2026, 1, 1)
        rows = [
            {
                "study_id": study_id,
                "token": secrets.token_urlsafe(18),
                "list_id": list_id,
                "number": 10_000_000 + i,
                "seed": i,
                "user_agent": "",
                "consented_at": long_ago,
                "started_at": long_ago,
                "finished_at": long_ago,
                "last_seen_at": long_ago,
                "pilot": False,
                "exclusion_reason": "",
            }
            for i in range(n)
        ]
        for start in range(0, n, 5000):
            db.session.execute(sa.insert(Participant), rows[start : start + 5000])
        db.session.commit()
        db.session.execute(sa.text("ANALYZE participant"))
        db.session.commit()


def _consents(app, study_id: int, count: int) -> list[float]:  # type: ignore[no-untyped-def]
    from app.web.extensions import db
    from app.web.models import Study
    from app.web.study.enrolment import enrol

    times = []
    with app.app_context():
        for _ in range(count):
            start = time.perf_counter()
            study = db.session.get(Study, study_id)
            enrol(
                study,
                dropped_after=dt.timedelta(minutes=30),
                unstarted=dt.timedelta(minutes=15),
            )
            db.session.commit()
            times.append((time.perf_counter() - start) * 1000)
            db.session.expunge_all()
    return times


def _plan(app, study_id: int) -> str:  # type: ignore[no-untyped-def]
    from app.web.extensions import db

    with app.app_context():
        rows = db.session.execute(
            sa.text(
                "EXPLAIN ANALYZE SELECT id, list_id FROM participant WHERE study_id = :s "
                "AND finished_at IS NULL AND dropped_at IS NULL AND last_seen_at < now()"
            ),
            {"s": study_id},
        ).scalars()
        return "\n".join("    " + r for r in rows)


def _index(app, present: bool) -> None:  # type: ignore[no-untyped-def]
    from app.web.extensions import db

    with app.app_context():
        if present:
            db.session.execute(
                sa.text(
                    "CREATE INDEX IF NOT EXISTS ix_participant_active ON participant "
                    "(study_id, last_seen_at) WHERE finished_at IS NULL AND dropped_at IS NULL"
                )
            )
        else:
            db.session.execute(sa.text("DROP INDEX IF EXISTS ix_participant_active"))
        db.session.commit()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=50_000)
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--per-round", type=int, default=40)
    args = parser.parse_args()
    name = f"facepair_bench_consent_{os.getpid()}"
    _admin(f"CREATE DATABASE {name}")
    try:
        url = f"postgresql+psycopg://postgres@{HOST}:{PORT}/{name}"
        with tempfile.TemporaryDirectory() as tmp:
            app = _app(url, Path(tmp) / "media")
            small, large = _study(app, Path(tmp)), _study(app, Path(tmp))
            _fill(app, large, args.size)
            _consents(app, small, 5)  # warm-up, discarded
            _consents(app, large, 5)
            results: dict[tuple[str, str], list[float]] = {}
            for _ in range(args.rounds):
                for present in (True, False):
                    _index(app, present)
                    build = "facepair" if present else "comparator"
                    for label, study_id in (("empty", small), ("large", large)):
                        results.setdefault((build, label), []).extend(
                            _consents(app, study_id, args.per_round)
                        )
            _index(app, True)
            print(f"consent, median ms ({args.rounds} x {args.per_round} a cell, alternating):")
            print(
                f"  {'':12} {'empty study':>12} {f'{args.size:,} earlier':>16} {'large/empty':>12}"
            )
            for build in ("facepair", "comparator"):
                empty = statistics.median(results[(build, "empty")])
                big = statistics.median(results[(build, "large")])
                print(f"  {build:12} {empty:12.2f} {big:16.2f} {big / empty:12.2f}")
            print("release query on the large study, facepair's schema:")
            print(_plan(app, large))
            with app.app_context():
                from app.web.extensions import db

                db.session.remove()
                db.engine.dispose()
    finally:
        _admin(f"DROP DATABASE IF EXISTS {name} WITH (FORCE)")


if __name__ == "__main__":
    main()
