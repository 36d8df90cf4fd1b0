"""``facepair leaderboard demo --out DIR``: a whole season on the embedded default, no network.

SQLite and local files in a working folder beside DIR (``DIR.season``, or ``--work``), jobs in
a spawned local process as the web's own (``JOB_RUNNER = "process"``), and the platform served
on 127.0.0.1 by a thread of this process. Then, as people would:

1. the benchmark is cut from the demo speech and the season created (its anchors rendered);
2. three systems made in three formats (a ``.fap``, an ARKit CSV, a BVH with three samples per
   segment) are submitted through the submission API, checked, rendered for their private
   previews, looked at and queued through the preview page;
3. round 1 is planned, rendered and opened; simulated participants with known preferences
   (:data:`app.leaderboard.demo.TRUE_STRENGTHS`) consent on the study page and vote through
   the HTTP API; the round is closed (report, package) and the board published to DIR;
4. a fourth system (a FAP CSV) is submitted, round 2 compares it with the anchors (the fixed
   ones and the top two), and the board is published again, round 1 untouched.

DIR then holds ``index.html``, ``leaderboard.json``, ``votes.csv``, ``leaderboard.css``, the
renders and each round's package: a static site for any web host.
"""

from __future__ import annotations

import logging
import re
import secrets
import shutil
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click

from app.commands.board import board_lines, season_software

#: The organiser of the demo season (a login on the working folder's database only).
ORGANISER = "organiser@example.org"
#: Simulated participants voting at once.
VOTING_THREADS = 3
_TRIAL_ID = re.compile(r'data-trial-id="(\d+)"')


@contextmanager
def _serving(app: Any) -> Iterator[str]:
    """The application on a free port of 127.0.0.1, in a thread; yields its base URL."""
    from werkzeug.serving import WSGIRequestHandler, make_server

    class Quiet(WSGIRequestHandler):
        def log_request(self, *args: Any, **kwargs: Any) -> None:
            pass

    server = make_server("127.0.0.1", 0, app, threaded=True, request_handler=Quiet)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.port}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=10)


def _wait(app: Any, job_ids: list[int], label: str) -> None:
    """Wait for the jobs with one progress bar; a failed job ends the demo (one line)."""
    import sqlalchemy as sa
    from tqdm import tqdm

    from app.errors import InputError
    from app.web.extensions import db
    from app.web.models import Job

    with app.app_context(), tqdm(desc=label, unit="step", leave=True) as bar:
        while True:
            db.session.expire_all()
            rows = db.session.scalars(sa.select(Job).where(Job.id.in_(job_ids))).all()
            bar.total = max(1, sum(max(r.total, 1) for r in rows))
            bar.n = sum(r.done if r.status != "done" else max(r.total, 1) for r in rows)
            bar.refresh()
            failed = [r for r in rows if r.status == "failed"]
            if failed:
                raise InputError(f"{label}: the {failed[0].kind} job failed: {failed[0].message}")
            if all(r.status == "done" for r in rows):
                db.session.remove()
                return
            db.session.remove()
            time.sleep(0.5)


def _submit(base: str, season: str, system: Any, files: list[Path]) -> str:
    """Submit a demo system through the API, look at its preview, return its preview path."""
    from app.errors import InputError
    from app.leaderboard.client import Client

    client = Client(base)
    fields = {
        "system": system.name,
        "team": f"{system.name} team",
        "contact": f"{system.name.lower()}@example.org",
        "paper": system.paper,
        "training_data": system.training_data,
        "licence": "1",
    }
    answer = client.post_files(
        f"/leaderboard/{season}/api/submissions", fields, [("files", f) for f in files]
    )
    if answer.status != 201:
        raise InputError(f"submitting {system.name}: {answer.status} {answer.text[:300]}")
    return answer.json()["preview"]


def _queue(base: str, preview: str) -> None:
    """The submitter looks at the rendered preview and queues the system."""
    from app.errors import InputError
    from app.leaderboard.client import Client

    client = Client(base)
    page = client.get(preview)
    if page.status != 200 or "Queue for the next round" not in page.text:
        raise InputError(f"the preview {preview} is not ready to queue ({page.status})")
    answer = client.post_form(f"{preview}/queue", {"csrf_token": client.csrf(preview)})
    if answer.status != 302:
        raise InputError(f"queueing {preview}: {answer.status}")


def _oracle(app: Any, trial_id: int) -> tuple[str, str, str, str, str | None]:
    """What a trial shows (the simulated participant's eyes): kind, left, right, mismatched
    side and expected answer."""
    from app.web.extensions import db
    from app.web.models import Trial

    with app.app_context():
        trial = db.session.get(Trial, trial_id)
        assert trial is not None
        stim = trial.stimulus
        found = (trial.kind, stim.left.name, stim.right.name, stim.foreign_side, trial.expected)
        db.session.remove()
        return found


def _participant(app: Any, base: str, slug: str, number: int, prefs: Any, seed: int) -> int:
    """One simulated participant from consent to the last vote; returns the votes cast."""
    import numpy as np

    from app.errors import InputError
    from app.leaderboard.client import Client
    from app.leaderboard.simulate import answer_catch, answer_mismatch, answer_pair

    rng = np.random.default_rng([seed, number])
    own = prefs.for_participant(rng)
    client = Client(base)
    link = f"/s/{slug}?PROLIFIC_PID=sim{seed}x{number}&STUDY_ID=demo&SESSION_ID=s{number}"
    consent = client.post_form(link, {"csrf_token": client.csrf(link), "agree": "1"})
    if consent.status != 302:
        raise InputError(f"participant {number}: consent answered {consent.status}")
    token = consent.headers["location"].split("/p/")[1].split("/")[0]
    page = client.get(f"/p/{token}/trial")
    found = _TRIAL_ID.search(page.text)
    trial = int(found.group(1)) if found else None
    votes = 0
    while trial is not None:
        kind, left, right, mismatched, expected = _oracle(app, trial)
        if kind == "catch":
            choice, strength = answer_catch(expected)
        elif mismatched:
            choice, strength = answer_mismatch(own, left, mismatched, rng)
        else:
            choice, strength = answer_pair(own, left, right, rng)
        client.post_json("/api/v1/plays", {"token": token, "trial_id": trial})
        answer = client.post_json(
            "/api/v1/votes",
            {
                "token": token,
                "trial_id": trial,
                "choice": choice,
                "strength": strength,
                "plays": 1,
                "watched_to_end": True,
                "response_ms": int(rng.integers(1500, 6000)),
                "idempotency_key": secrets.token_hex(12),
            },
        )
        if answer.status not in (200, 201):
            raise InputError(f"participant {number}: vote answered {answer.status} {answer.text}")
        votes += 1
        following = answer.json().get("next_trial")
        trial = int(following["trial_id"]) if following else None
    return votes


def _vote(app: Any, base: str, slug: str, participants: int, seed: int, label: str) -> int:
    """Every simulated participant of a round, a few at a time; returns the votes cast."""
    from tqdm import tqdm

    from app.leaderboard.demo import TRUE_COHERENCE, TRUE_STRENGTHS
    from app.leaderboard.simulate import Preferences

    prefs = Preferences(_by_code(app, TRUE_STRENGTHS), _by_code(app, TRUE_COHERENCE))
    total = 0
    with tqdm(total=participants, desc=label, unit="participant") as bar:
        with ThreadPoolExecutor(max_workers=VOTING_THREADS) as pool:
            futures = [
                pool.submit(_participant, app, base, slug, k, prefs, seed)
                for k in range(1, participants + 1)
            ]
            for future in futures:
                total += future.result()
                bar.update(1)
    return total


def _by_code(app: Any, by_name: Any) -> dict[str, float]:
    """The demo's truths keyed by the systems' codes (the names in the studies)."""
    import sqlalchemy as sa

    from app.web.board.models import BoardSystem
    from app.web.extensions import db

    with app.app_context():
        rows = db.session.execute(sa.select(BoardSystem.code, BoardSystem.name, BoardSystem.model))
        out = {}
        for code, name, model in rows:
            key = name if name in by_name else model
            if key in by_name:
                out[code] = float(by_name[key])
        db.session.remove()
        return out


def _round(app: Any, base: str, season_name: str, participants: int, seed: int, out: Path) -> dict:  # type: ignore[type-arg]
    """Plan, render, open, vote, close and publish the next round; returns the board."""
    from app.web.board.publish import export_static, publish
    from app.web.board.rounds import close_round, create_round, open_round
    from app.web.board.seasons import start_jobs
    from app.web.extensions import db

    with app.app_context():
        rnd, jobs = create_round(_season_named(season_name))
        db.session.commit()
        number, slug = rnd.number, rnd.study.slug
        start_jobs(app, jobs)
    _wait(app, jobs, f"round {number}: tracks and clips")
    with app.app_context():
        open_round(_round_row(season_name, number))
        db.session.commit()
    _vote(app, base, slug, participants, seed + number, f"round {number}: voting")
    with app.app_context():
        jobs = close_round(_round_row(season_name, number))
        db.session.commit()
        start_jobs(app, jobs)
    _wait(app, jobs, f"round {number}: report")
    with app.app_context(), app.test_request_context():
        season = _season_named(season_name)
        board = publish(season)
        db.session.commit()
        export_static(season, out)
        return board


def _round_row(season_name: str, number: int) -> Any:
    from app.web.board.rounds import round_by_number

    return round_by_number(_season_named(season_name), number)


def _season_named(name: str) -> Any:
    """The demo's season (made at its start; its absence is a broken working folder)."""
    from app.errors import InputError
    from app.web.board.seasons import season_by_name

    season = season_by_name(name)
    if season is None:
        raise InputError(f"no season {name!r} in the working folder's database", field="--work")
    return season


@click.command("demo")
@click.option(
    "--out",
    required=True,
    type=click.Path(file_okay=False, path_type=Path),
    help="Where the published board goes (index.html, leaderboard.json, ...).",
)
@click.option(
    "--work",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="The season's database and media (default: OUT.season beside OUT); emptied.",
)
@click.option(
    "--participants",
    default=30,
    show_default=True,
    type=click.IntRange(4, 500),
    help="Simulated participants per round.",
)
@click.option("--seed", default=0, show_default=True, type=int)
def demo(out: Path, work: Path | None, participants: int, seed: int) -> None:
    """Run a whole season on the embedded default with simulated participants and publish it
    to OUT (about three minutes on two idle cores, mostly rendering the rounds' clips)."""
    from flask_migrate import upgrade

    from app.leaderboard.demo import SYSTEMS, write_benchmark, write_systems
    from app.leaderboard.season import load_season_file
    from app.web import create_app
    from app.web.board.seasons import create_season, start_jobs
    from app.web.extensions import db
    from app.web.infra.accounts import create_user

    started = time.monotonic()
    out = out.resolve()
    work = (work or out.with_name(out.name + ".season")).resolve()
    if work == out or out in work.parents:
        raise click.BadParameter(
            "must lie outside --out (it holds the ground truth)", param_hint="--work"
        )
    shutil.rmtree(work, ignore_errors=True)
    (work / "media").mkdir(parents=True)
    app = create_app(
        {
            "SQLALCHEMY_DATABASE_URI": f"sqlite:///{work / 'facepair.sqlite'}",
            "MEDIA_ROOT": str(work / "media"),
            "SECRET_KEY": secrets.token_hex(32),
            "REDIS_URL": None,
            "JOB_RUNNER": "process",
            "LEADERBOARD_UPLOAD_LIMIT": "",
            # every simulated participant arrives from 127.0.0.1
            "CONSENT_LIMIT_PER_ADDRESS": "",
            "CONSENT_LIMIT_PER_STUDY": "",
        }
    )
    if not logging.getLogger().handlers:
        # warnings only: the migrations' progress lines would bury the demo's own
        # (app/web/migrations/env.py leaves logging to a caller that set it up)
        logging.basicConfig(level=logging.WARNING, format="facepair: %(levelname)s: %(message)s")
    with app.app_context():
        upgrade()
        create_user(ORGANISER, secrets.token_urlsafe(24))
        db.session.commit()
    click.echo("making the benchmark and the demo systems ...", err=True)
    bench = work / "inputs" / "benchmark"
    season_file = write_benchmark(bench, organiser=ORGANISER)
    made = write_systems(bench, work / "inputs" / "systems")
    spec = load_season_file(season_file)
    with app.app_context():
        season, jobs = create_season(
            spec, season_file.read_text(encoding="utf-8"), software=season_software()
        )
        db.session.commit()
        name = season.name
        start_jobs(app, jobs)
    _wait(app, jobs, "anchors: tracks and clips")
    board: dict = {}  # type: ignore[type-arg]
    with _serving(app) as base:
        for number in (1, 2):
            entering = [s for s in SYSTEMS if s.round == number]
            previews = [_submit(base, name, s, made[s.name]) for s in entering]
            with app.app_context():
                jobs = _preview_jobs(name)
            _wait(app, jobs, f"round {number}: previews")
            for preview in previews:
                _queue(base, preview)
            board = _round(app, base, name, participants, seed, out)
    for line in board_lines(board):
        click.echo(line)
    minutes, seconds = divmod(time.monotonic() - started, 60)
    click.echo(f"published to {out / 'index.html'} in {int(minutes)} min {seconds:.0f} s")


def _preview_jobs(season_name: str) -> list[int]:
    """The preview jobs of the season's systems still being previewed."""
    import sqlalchemy as sa

    from app.web.board.models import BoardSystem
    from app.web.extensions import db
    from app.web.models import Job

    season = _season_named(season_name)
    studies = db.session.scalars(
        sa.select(BoardSystem.preview_study_id).where(
            BoardSystem.season_id == season.id, BoardSystem.status == "previewing"
        )
    ).all()
    return list(db.session.scalars(sa.select(Job.id).where(Job.study_id.in_(studies))))
