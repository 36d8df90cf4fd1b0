"""``facepair leaderboard``: a season from the shell, with the web's services
(:mod:`app.web.board`): ``season create``, ``submit``, ``queue``, ``round create/open/close``,
``publish``, ``status`` and ``demo`` (:mod:`app.commands.leaderboard_demo`).

Jobs a command starts (the anchors', a preview's or a round's renders, a round's report) go to
the deployment's workers when ``REDIS_URL`` is set, as the studies' do; without it they run in
this process with a progress bar.
"""

from __future__ import annotations

from pathlib import Path

import click

from app.commands.board import board_lines, season_software
from app.commands.db import migrated
from app.commands.leaderboard_demo import demo
from app.commands.webapp import app_context, offline_app
from app.errors import InputError


def _season(name: str):  # type: ignore[no-untyped-def]
    from app.web.board.seasons import season_by_name

    found = season_by_name(name)
    if found is None:
        raise InputError(f"no season {name!r} (see 'facepair leaderboard status')", field="SEASON")
    return found


def run_jobs(job_ids: list[int]) -> None:
    """Start committed job rows: on the RQ workers with ``REDIS_URL``, else here, each with a
    progress bar; a failed job is one line (exit 2)."""
    from flask import current_app
    from tqdm import tqdm

    from app.web.extensions import db
    from app.web.jobs.bodies import run_job
    from app.web.models import Job

    if current_app.config.get("REDIS_URL"):
        from app.web.board.seasons import start_jobs

        start_jobs(current_app._get_current_object(), job_ids)  # type: ignore[attr-defined]
        click.echo(f"{len(job_ids)} job(s) queued for the workers", err=True)
        return
    for job_id in job_ids:
        kind = db.session.get(Job, job_id).kind  # type: ignore[union-attr]
        with tqdm(desc=kind, unit="step", leave=False) as bar:

            def echo(done: int, total: int, bar: tqdm = bar) -> None:
                bar.total = total
                bar.n = done
                bar.refresh()

            status = run_job(job_id, echo=echo)
        if status != "done":
            db.session.expire_all()
            message = db.session.get(Job, job_id).message  # type: ignore[union-attr]
            raise InputError(f"the {kind} job failed: {message}")


@click.group()
def leaderboard() -> None:
    """A standing, public evaluation of talking-face motion: seasons, submissions, rounds."""


@leaderboard.group()
def season() -> None:
    """Create a season from its file."""


@season.command("create")
@click.argument("season_file", type=click.Path(dir_okay=False, path_type=Path))
def season_create(season_file: Path) -> None:
    """Create a season from SEASON_FILE (TOML; keys in docs/guide/leaderboard.md): its
    segments kept, its manifest written, its anchors rendered."""
    from app.leaderboard.season import load_season_file
    from app.web.extensions import db

    spec = load_season_file(season_file)
    app = offline_app()
    with app_context(app):
        migrated()
        from app.web.board.seasons import create_season

        created, jobs = create_season(
            spec, season_file.read_text(encoding="utf-8"), software=season_software()
        )
        db.session.commit()
        run_jobs(jobs)
        click.echo(f"season {created.name} created; manifest {created.manifest_sha256}")


@leaderboard.command("submit")
@click.argument("season_name", metavar="SEASON")
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--system", required=True, help="The system's name.")
@click.option("--team", default="", help="The team (new submitters).")
@click.option("--contact", default="", help="A contact e-mail (new submitters).")
@click.option("--key", default="", help="The submitter key a first submission gave.")
@click.option("--paper", default="", help="Paper or preprint link.")
@click.option("--training-data", default="", help="What the system was trained on.")
@click.option("--grant-licence", is_flag=True, help="Grant the season's licence (required).")
@click.option("--anonymous-name", default="", help="Name shown until --anonymous-until.")
@click.option("--anonymous-until", default="", help="Date (YYYY-MM-DD) anonymity ends.")
@click.option("--url", default=None, help="Send it to this server instead of the local database.")
def submit(
    season_name: str,
    files: tuple[Path, ...],
    system: str,
    team: str,
    contact: str,
    key: str,
    paper: str,
    training_data: str,
    grant_licence: bool,
    anonymous_name: str,
    anonymous_until: str,
    url: str | None,
) -> None:
    """Submit FILES (one track per segment, any format facepair imports) as a system of SEASON.
    Every problem is one line naming the file (exit 2); a passing submission is rendered for
    its private preview, whose link is printed."""
    fields = {
        "system": system,
        "team": team,
        "contact": contact,
        "key": key,
        "paper": paper,
        "training_data": training_data,
        "licence": "1" if grant_licence else "",
        "anonymous_name": anonymous_name,
        "anonymous_until": anonymous_until,
    }
    missing = [str(f) for f in files if not f.is_file()]
    if missing:
        raise InputError("no such file", path=missing[0])
    if url:
        _submit_remote(url, season_name, fields, files)
        return
    from app.web.board.submissions import Description, SubmissionRefused
    from app.web.board.submissions import submit as submit_system
    from app.web.extensions import db

    app = offline_app()
    with app_context(app):
        migrated()
        found = _season(season_name)
        try:
            made, new_key, jobs = submit_system(
                found, Description.from_mapping(fields), {f.name: f for f in files}
            )
        except SubmissionRefused as exc:
            _refused(exc.problems)
        db.session.commit()
        run_jobs(jobs)
        click.echo(f"system {made.name} ({made.code}) passed its checks")
        if new_key:
            click.echo(f"submitter key (shown once): {new_key}")
        click.echo(f"private preview: /leaderboard/{found.name}/preview/{made.preview_token}")


def _refused(problems: list[str]) -> None:
    for line in problems:
        click.echo(f"facepair: error: {line}", err=True)
    raise SystemExit(2)


def _submit_remote(
    url: str, season_name: str, fields: dict[str, str], files: tuple[Path, ...]
) -> None:
    from app.leaderboard.client import Client

    answer = Client(url).post_files(
        f"/leaderboard/{season_name}/api/submissions", fields, [("files", f) for f in files]
    )
    if answer.status == 400:
        try:
            _refused(list(answer.json().get("errors", [answer.text[:200]])))
        except ValueError:
            _refused([answer.text.strip()[:200]])
    if answer.status != 201:
        raise InputError(f"the server answered {answer.status}", field="--url")
    body = answer.json()
    click.echo(f"system {body['system']} ({body['code']}) passed its checks")
    if body.get("key"):
        click.echo(f"submitter key (shown once): {body['key']}")
    click.echo(f"private preview: {body['preview']}")


@leaderboard.command("queue")
@click.argument("season_name", metavar="SEASON")
@click.argument("system")
def queue(season_name: str, system: str) -> None:
    """Queue a previewed SYSTEM (its name or code) for the next round (what its submitter's
    preview page does)."""
    import sqlalchemy as sa

    from app.web.board.models import BoardSystem
    from app.web.board.submissions import queue_system
    from app.web.extensions import db

    with app_context(offline_app()):
        migrated()
        found = _season(season_name)
        row = db.session.scalar(
            sa.select(BoardSystem).where(
                BoardSystem.season_id == found.id,
                sa.or_(BoardSystem.name == system, BoardSystem.code == system),
            )
        )
        if row is None:
            raise InputError(f"no system {system!r} in season {found.name}", field="SYSTEM")
        queue_system(row)
        db.session.commit()
        click.echo(f"{row.name} queued for the next round")


@leaderboard.group("round")
def round_group() -> None:
    """Create, open and close a season's rounds."""


@round_group.command("create")
@click.argument("season_name", metavar="SEASON")
def round_create(season_name: str) -> None:
    """The next round: every queued system with the anchors, pairs planned by information
    gain, its study made and rendered."""
    from app.web.board.rounds import create_round, plan_lines
    from app.web.extensions import db

    with app_context(offline_app()):
        migrated()
        made, jobs = create_round(_season(season_name))
        db.session.commit()
        click.echo(f"round {made.number}: study {made.study_id}, systems {', '.join(made.systems)}")
        for line in plan_lines(made):
            click.echo(f"  {line}")
        run_jobs(jobs)


@round_group.command("open")
@click.argument("season_name", metavar="SEASON")
@click.option("--round", "number", type=int, default=None, help="Default: the latest.")
def round_open(season_name: str, number: int | None) -> None:
    """Open a rendered round to participants and print its link."""
    from flask import url_for

    from app.web.board.rounds import open_round, round_by_number
    from app.web.extensions import db

    app = offline_app()
    with app_context(app):
        migrated()
        found = round_by_number(_season(season_name), number)
        open_round(found)
        db.session.commit()
        with app.test_request_context():
            link = url_for("participant.start", slug=found.study.slug)
        click.echo(
            f"round {found.number} open: participant link {link}; recruit on Prolific with "
            f"'facepair prolific publish {found.study_id}' (the season's [test.prolific])"
        )


@round_group.command("close")
@click.argument("season_name", metavar="SEASON")
@click.option("--round", "number", type=int, default=None, help="Default: the latest.")
def round_close(season_name: str, number: int | None) -> None:
    """Close a round and write its report (its votes and package are then final)."""
    from app.web.board.rounds import close_round, round_by_number
    from app.web.extensions import db

    with app_context(offline_app()):
        migrated()
        found = round_by_number(_season(season_name), number)
        jobs = close_round(found)
        db.session.commit()
        run_jobs(jobs)
        click.echo(f"round {found.number} closed")


@leaderboard.command("publish")
@click.argument("season_name", metavar="SEASON")
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Also write the board as a static site (index.html, leaderboard.json, ...).",
)
def publish(season_name: str, out: Path | None) -> None:
    """Fit every closed round's votes, check the anchors for drift, publish the board."""
    from app.web.board.publish import export_static
    from app.web.board.publish import publish as publish_board
    from app.web.extensions import db

    app = offline_app()
    with app_context(app):
        migrated()
        found = _season(season_name)
        board = publish_board(found)
        db.session.commit()
        for line in board_lines(board):
            click.echo(line)
        if out is not None:
            with app.test_request_context():
                written = export_static(found, out)
            click.echo(f"{len(written)} files written to {out}")


@leaderboard.command("status")
@click.argument("season_name", metavar="SEASON", required=False)
def status(season_name: str | None) -> None:
    """The seasons, or one season's systems and rounds."""
    import sqlalchemy as sa

    from app.web.board.models import Season
    from app.web.board.rounds import rounds_of, systems_of
    from app.web.extensions import db

    with app_context(offline_app()):
        migrated()
        if season_name is None:
            for row in db.session.scalars(sa.select(Season).order_by(Season.id)):
                click.echo(f"{row.name}  {row.status}  {row.title}")
            return
        found = _season(season_name)
        click.echo(f"{found.name}: {found.status}, manifest {found.manifest_sha256}")
        for row in systems_of(found):
            click.echo(f"  system {row.code:<14} {row.status:<10} {row.name}")
        for rnd in rounds_of(found):
            click.echo(f"  round {rnd.number}: {rnd.status}, study {rnd.study_id}")


def register(main: click.Group) -> None:
    leaderboard.add_command(demo)
    main.add_command(leaderboard)
