"""Web commands: ``facepair serve``, ``worker``, ``experimenter add`` (``demo``:
:mod:`app.commands.demo`).

The database schema comes from the migrations (``facepair db upgrade``, :mod:`app.commands.db`);
``demo`` runs that upgrade itself on the embedded SQLite default, every other command expects it
done (and says so in one line where it is not: :func:`app.commands.db.migrated`).
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click

from app.errors import InputError


def _app(**config: Any):  # type: ignore[no-untyped-def]
    from app.web import create_app

    return create_app(config or None)


def _offline_app():  # type: ignore[no-untyped-def]
    """The app for commands that answer no web request: no session is ever signed, so no
    deployment key is needed."""
    return _app(REQUIRE_SECRET_KEY=False)


@contextmanager
def _context(app):  # type: ignore[no-untyped-def]
    """An application context whose database connections are closed on the way out."""
    from app.web.extensions import db

    with app.app_context():
        try:
            yield
        finally:
            db.session.remove()
            db.engine.dispose()


def _run_jobs(study_id: int, kinds: tuple[str, ...]) -> None:
    """Run jobs in this process with a progress bar each (on stderr); a failed job is an
    error."""
    from tqdm import tqdm

    from app.web.extensions import transaction
    from app.web.jobs.tasks import run_job
    from app.web.models import Job

    for kind in kinds:
        with transaction() as session:
            job = Job(study_id=study_id, kind=kind)
            session.add(job)
        with tqdm(desc=kind, unit="step", file=None, leave=True) as bar:

            def echo(done: int, total: int, bar: tqdm = bar) -> None:
                bar.total = total
                bar.n = done
                bar.refresh()

            status = run_job(job.id, echo=echo)
        from app.web.extensions import db

        job = db.session.get(Job, job.id)
        if status != "done":
            raise click.ClickException(f"{kind} failed: {job.message}")  # type: ignore[union-attr]


def _create_study(path: Path, owner_email: str) -> int:
    import sqlalchemy as sa

    from app.trials.studyfile import load_study_file
    from app.web.extensions import db
    from app.web.models import User
    from app.web.study.studies import create_study

    owner = db.session.scalar(sa.select(User).where(User.email == owner_email.lower()))
    if owner is None:
        raise InputError(
            f"no experimenter {owner_email!r} (add one with 'facepair experimenter add')",
            field="--owner",
        )
    spec = load_study_file(path)
    study = create_study(owner, spec, source_toml=path.read_text(encoding="utf-8"))
    db.session.commit()
    return study.id


def _serve(  # type: ignore[no-untyped-def]
    app, host: str, port: int, workers: int, dev: bool, log: Path | None = None
) -> None:
    """Serve ``app`` with gunicorn (``dev``: Flask's server). With ``log`` (the demo, on this
    machine alone) gunicorn's messages and access log go to that file and the warning about a
    missing front proxy, a production matter, is not shown."""
    if dev:
        app.run(host=host, port=port, threaded=True, use_reloader=False)
        return
    from gunicorn.app.base import BaseApplication

    from app.web.serving import proxy_warning, settings

    warning = proxy_warning(int(app.config.get("TRUST_PROXY") or 0))
    if warning and log is None:
        click.echo(warning, err=True)
    chosen = settings(host, port, workers)
    if log is not None:
        chosen |= {"errorlog": str(log), "accesslog": str(log)}

    class Server(BaseApplication):  # type: ignore[misc]
        def load_config(self) -> None:
            for key, value in chosen.items():
                self.cfg.set(key, value)

        def load(self):  # type: ignore[no-untyped-def]
            return app

    Server().run()


@click.command()
@click.option("--host", default="127.0.0.1", show_default=True)
@click.option("--port", default=5000, show_default=True, type=int)
@click.option("--workers", default=2, show_default=True, type=int, help="gunicorn workers")
@click.option("--dev", is_flag=True, help="Flask's development server instead of gunicorn.")
def serve(host: str, port: int, workers: int, dev: bool) -> None:
    """Serve the web application (gunicorn; the schema must be migrated first)."""
    _serve(_app(), host, port, workers, dev)


@click.command()
@click.option(
    "--name",
    default=None,
    help="The worker's name in RQ and on each clip it renders (default: random).",
)
def worker(name: str | None) -> None:
    """Run an RQ worker for the background jobs (needs REDIS_URL); start one on each machine
    that should render (docs/operations.md, "Render workers")."""
    app = _offline_app()
    url = app.config.get("REDIS_URL")
    if not url:
        raise InputError(
            "set REDIS_URL to run a worker (without it jobs run in the web process)",
            field="REDIS_URL",
        )
    from redis import Redis

    from app.web.jobs.tasks import rq_horse_killed
    from app.web.jobs.worker import Worker

    with app.app_context():
        Worker(
            ["facepair"],
            connection=Redis.from_url(url),
            name=name,
            work_horse_killed_handler=rq_horse_killed,
        ).work()


@click.group()
def experimenter() -> None:
    """Manage experimenter accounts."""


@experimenter.command("add")
@click.argument("email")
@click.password_option(help="At least 12 characters, not a common password.")
def add(email: str, password: str) -> None:
    """Add an experimenter who can log in at /experimenter/login."""
    from app.commands.db import migrated
    from app.web.extensions import db
    from app.web.infra.accounts import create_user

    app = _offline_app()
    with _context(app):
        migrated()
        user = create_user(email, password)
        db.session.commit()
        click.echo(f"experimenter {user.email} added")


@experimenter.command("password")
@click.argument("email")
@click.password_option(help="The new password: at least 12 characters, not a common one.")
def password(email: str, password: str) -> None:
    """Set an experimenter's password and end every login they have (all their browsers)."""
    import sqlalchemy as sa

    from app.commands.db import migrated
    from app.web.extensions import db
    from app.web.infra.accounts import change_password
    from app.web.models import User

    app = _offline_app()
    with _context(app):
        migrated()
        user = db.session.scalar(sa.select(User).where(User.email == email.strip().lower()))
        if user is None:
            raise InputError(f"no experimenter {email.strip().lower()}", field="email")
        ended = change_password(user, password)
        db.session.commit()
        click.echo(f"password of {user.email} changed; {ended} login(s) ended")


@experimenter.command("unlock")
@click.argument("email")
@click.option(
    "--site",
    default="",
    metavar="URL",
    help="The site's address (https://studies.example.org), put before the link's path.",
)
def unlock(email: str, site: str) -> None:
    """Print a link that lets one browser log in to EMAIL although others' failed logins hold
    the account or its network at 429 (too many attempts). Opened within an hour, it gives
    that browser a login-limit count of its own; the password is still needed. Run it with
    the server's SECRET_KEY (its environment or instance config)."""
    import sqlalchemy as sa

    from app.commands.db import migrated
    from app.web.experimenter.views import UNLOCK_MINUTES, unlock_token
    from app.web.extensions import db
    from app.web.models import User

    app = _app()
    with _context(app):
        migrated()
        address = email.strip().lower()
        user = db.session.scalar(sa.select(User).where(User.email == address))
        if user is None:
            raise InputError(f"no experimenter {address}", field="email")
        token = unlock_token(user.email)
    link = f"{site.rstrip('/')}/experimenter/login?unlock={token}"
    click.echo(
        f"open this link in the browser that will log in as {user.email} "
        f"(valid {UNLOCK_MINUTES} minutes; it does not log in by itself):\n  {link}"
    )


def register(main: click.Group) -> None:
    from app.commands.demo import demo

    for command in (serve, worker, experimenter, demo):
        main.add_command(command)
