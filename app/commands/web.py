"""Web commands: ``facepair serve``, ``demo``, ``worker``, ``experimenter add``.

The database schema comes from the migrations (``facepair db upgrade``, :mod:`app.commands.db`);
``demo`` runs that upgrade itself on the embedded SQLite default, every other command expects it
done (and says so in one line where it is not: :func:`app.commands.db.migrated`).
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click

from app.data import data_path
from app.errors import InputError

DEMO_EMAIL = "demo@example.org"
DEMO_PASSWORD = "facepair-demo"


def _app(**config: Any):  # type: ignore[no-untyped-def]
    from app.web import create_app

    return create_app(config or None)


def _offline_app():  # type: ignore[no-untyped-def]
    """The app for commands that answer no web request: no session is ever signed, so no
    deployment key is needed."""
    return _app(REQUIRE_SECRET_KEY=False)


def _demo_app():  # type: ignore[no-untyped-def]
    """The demo's app: only on its embedded SQLite file (it writes a publicly known login), with
    ``SECRET_KEY`` from the environment or a random key kept in the instance folder."""
    import os

    from app.web import embedded_database_uri
    from app.web.infra.security import stored_secret_key

    probe = _offline_app()
    if probe.config["SQLALCHEMY_DATABASE_URI"] != embedded_database_uri(probe.instance_path):
        raise InputError(
            "the demo runs only on its embedded SQLite file (it creates the "
            "public demo login); unset DATABASE_URL",
            field="DATABASE_URL",
        )
    if os.environ.get("SECRET_KEY"):
        return _app()
    return _app(SECRET_KEY=stored_secret_key(Path(probe.instance_path)))


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
    """Run jobs in this process with a progress bar each; a failed job is an error."""
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


def _jobs_child(study_id: int, kinds: tuple[str, ...], config: dict[str, Any]) -> None:
    app = _app(**config)
    try:
        with _context(app):
            _run_jobs(study_id, kinds)
    except click.ClickException as exc:
        click.echo(f"facepair: error: {exc.message}", err=True)
        raise SystemExit(1) from None


def _run_jobs_apart(app, study_id: int, kinds: tuple[str, ...]) -> None:  # type: ignore[no-untyped-def]
    """:func:`_run_jobs` in a spawned process: a process that is about to serve (and fork
    gunicorn workers) must never hold a GL context, or the forked workers hang in it."""
    import multiprocessing

    config = {
        "REQUIRE_SECRET_KEY": False,
        "SQLALCHEMY_DATABASE_URI": app.config["SQLALCHEMY_DATABASE_URI"],
        "MEDIA_ROOT": app.config["MEDIA_ROOT"],
    }
    process = multiprocessing.get_context("spawn").Process(
        target=_jobs_child, args=(study_id, kinds, config), name="facepair-demo-jobs"
    )
    process.start()
    process.join()
    if process.exitcode != 0:
        raise click.ClickException(
            f"{' and '.join(kinds)} of study {study_id} failed (exit code {process.exitcode})"
        )


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


def _serve(app, host: str, port: int, workers: int, dev: bool) -> None:  # type: ignore[no-untyped-def]
    if dev:
        app.run(host=host, port=port, threaded=True, use_reloader=False)
        return
    from gunicorn.app.base import BaseApplication

    from app.web.serving import proxy_warning, settings

    warning = proxy_warning(int(app.config.get("TRUST_PROXY") or 0))
    if warning:
        click.echo(warning, err=True)

    class Server(BaseApplication):  # type: ignore[misc]
        def load_config(self) -> None:
            for key, value in settings(host, port, workers).items():
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


@click.command()
@click.option("--host", default="127.0.0.1", show_default=True)
@click.option("--port", default=5000, show_default=True, type=int)
@click.option(
    "--study-file",
    type=click.Path(dir_okay=False, path_type=Path),
    default=data_path("examples", "study.toml"),
    show_default=True,
)
@click.option("--no-serve", is_flag=True, help="Set everything up, print the URLs, exit.")
def demo(host: str, port: int, study_file: Path, no_serve: bool) -> None:
    """Migrate the embedded database, create a demo experimenter and a ready, open demo study
    (tracks generated, clips rendered from the demo speech), then serve it."""
    import sqlalchemy as sa
    from flask_migrate import upgrade

    from app.web.extensions import db
    from app.web.infra.accounts import create_user
    from app.web.models import Study, User

    app = _demo_app()
    with _context(app):
        upgrade()
        user = db.session.scalar(sa.select(User).where(User.email == DEMO_EMAIL))
        if user is None:
            user = create_user(DEMO_EMAIL, DEMO_PASSWORD)
            db.session.commit()
        study = db.session.scalar(
            sa.select(Study)
            .where(Study.owner_id == user.id, Study.status == "open")
            .order_by(Study.id.desc())
        )
        if study is None:
            click.echo(f"creating the demo study from {study_file} ...", err=True)
            study_id = _create_study(study_file, DEMO_EMAIL)
            _run_jobs_apart(app, study_id, ("generate", "render"))
            study = db.session.get(Study, study_id)
            study.status = "open"  # type: ignore[union-attr]
            db.session.commit()
        slug, study_id = study.slug, study.id  # type: ignore[union-attr]
    base = f"http://{host}:{port}"
    click.echo(
        f"\n  participant:   {base}/s/{slug}\n"
        f"  experimenter:  {base}/experimenter/studies/{study_id}\n"
        f"  login:         {DEMO_EMAIL} / {DEMO_PASSWORD}\n"
    )
    if not no_serve:
        _serve(app, host, port, workers=1, dev=False)


def register(main: click.Group) -> None:
    for command in (serve, worker, experimenter, demo):
        main.add_command(command)
