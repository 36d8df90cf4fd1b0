"""Web commands: ``facepair serve``, ``worker``, ``experimenter add`` (``demo``:
:mod:`app.commands.demo`).

The database schema comes from the migrations (``facepair db upgrade``, :mod:`app.commands.db`);
``demo`` runs that upgrade itself on the embedded SQLite default, every other command expects it
done (and says so in one line where it is not: :func:`app.commands.db.migrated`). The
application they run and serve is built by :mod:`app.commands.webapp`.
"""

from __future__ import annotations

import click

from app.commands.db import migrated
from app.commands.demo import demo
from app.commands.webapp import app_context, offline_app, serve_app, web_app
from app.errors import InputError


@click.command()
@click.option("--host", default="127.0.0.1", show_default=True)
@click.option("--port", default=5000, show_default=True, type=int)
@click.option("--workers", default=2, show_default=True, type=int, help="gunicorn workers")
@click.option("--dev", is_flag=True, help="Flask's development server instead of gunicorn.")
def serve(host: str, port: int, workers: int, dev: bool) -> None:
    """Serve the web application (gunicorn; the schema must be migrated first)."""
    serve_app(web_app(), host, port, workers, dev)


@click.command()
@click.option(
    "--name",
    default=None,
    help="The worker's name in RQ and on each clip it renders (default: random).",
)
def worker(name: str | None) -> None:
    """Run an RQ worker for the background jobs (needs REDIS_URL); start one on each machine
    that should render (docs/operations.md, "Render workers")."""
    app = offline_app()
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
    from app.web.extensions import db
    from app.web.infra.accounts import create_user

    app = offline_app()
    with app_context(app):
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

    from app.web.extensions import db
    from app.web.infra.accounts import change_password
    from app.web.models import User

    app = offline_app()
    with app_context(app):
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

    from app.web.experimenter.views import UNLOCK_MINUTES, unlock_token
    from app.web.extensions import db
    from app.web.models import User

    app = web_app()
    with app_context(app):
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
    for command in (serve, worker, experimenter, demo):
        main.add_command(command)
