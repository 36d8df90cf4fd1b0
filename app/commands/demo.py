"""``facepair demo``: the platform on this machine with a ready study, in one command.

A newcomer is greeted with what they need and little else: the participant link, the
experimenter link, the login (``demo@example.org`` and a password generated on the first run)
and the path of the demo's log file, where everything else goes: the migrations' messages, the
jobs' progress bars, Python's warnings and the server's log (``instance/demo.log`` unless
``--log``; ``make demo`` writes its set-up there too). The demo serves on this machine alone,
so ``facepair serve``'s warning about a missing front proxy is not shown.

It runs only on its embedded SQLite file (it writes a login it prints); without ``SECRET_KEY`` it
keeps a random key in the instance folder.
"""

from __future__ import annotations

import logging
import os
import secrets
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click

from app.commands.studysetup import create_from_file, run_jobs_here
from app.commands.webapp import app_context, offline_app, serve_app, web_app
from app.data import data_path
from app.errors import InputError

DEMO_EMAIL = "demo@example.org"
#: The demo password's letters: none a reader confuses with another (0/o, 1/l/i).
PASSWORD_LETTERS = "abcdefghjkmnpqrstuvwxyz23456789"
#: The log file's name in the instance folder, and its lines.
LOG_NAME = "demo.log"
LOG_FORMAT = "%(asctime)s %(levelname)s [%(name)s] %(message)s"


def demo_password(instance: Path) -> str:
    """The demo login's password: three groups of four letters (``k7mq-2xbn-p4rt``),
    generated on first use and kept in ``instance/demo_password``, readable by the owner only.

    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> first = demo_password(folder)
    >>> len(first), first == demo_password(folder)
    (14, True)
    """
    path = instance / "demo_password"
    if path.is_file():
        stored = path.read_text(encoding="ascii").strip()
        if len(stored) == 14:
            return stored
    password = "-".join(
        "".join(secrets.choice(PASSWORD_LETTERS) for _ in range(4)) for _ in range(3)
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    path.touch(mode=0o600)
    path.write_text(password + "\n", encoding="ascii")
    return password


def greeting(base: str, participants: list[str], study_id: int, password: str, log: Path) -> str:
    """What the demo prints once it is ready: the participant link of each study in
    ``participants`` (slugs), the experimenter link, the login and the log file.

    >>> print(greeting("http://127.0.0.1:5000", ["abc"], 1, "k7mq-2xbn-p4rt", Path("/x/demo.log")))
    <BLANKLINE>
      participant:   http://127.0.0.1:5000/s/abc
      experimenter:  http://127.0.0.1:5000/experimenter/studies/1
      login:         demo@example.org / k7mq-2xbn-p4rt
      log:           /x/demo.log
    <BLANKLINE>
    """
    lines = [f"  participant:   {base}/s/{slug}" for slug in participants]
    lines += [
        f"  experimenter:  {base}/experimenter/studies/{study_id}",
        f"  login:         {DEMO_EMAIL} / {password}",
        f"  log:           {log}",
    ]
    return "\n" + "\n".join(lines) + "\n"


class _NotWarnings(logging.Filter):
    """Python's warnings (deprecations in libraries) are the log file's, not the terminal's."""

    def filter(self, record: logging.LogRecord) -> bool:
        return record.name != "py.warnings"


@contextmanager
def demo_logging(log: Path) -> Iterator[None]:
    """Everything logged at INFO and above, and Python's warnings, into ``log``; only
    warnings and errors of the demo's own work on the terminal (the migrations' INFO lines do
    not reach it: ``app/web/migrations/env.py`` leaves logging to a caller that set it up)."""
    log.parent.mkdir(parents=True, exist_ok=True)
    root = logging.getLogger()
    to_file = logging.FileHandler(log, encoding="utf-8")
    to_file.setFormatter(logging.Formatter(LOG_FORMAT))
    to_terminal = logging.StreamHandler(sys.stderr)
    to_terminal.setLevel(logging.WARNING)
    to_terminal.addFilter(_NotWarnings())
    to_terminal.setFormatter(logging.Formatter("facepair demo: %(levelname)s: %(message)s"))
    level = root.level
    root.addHandler(to_file)
    root.addHandler(to_terminal)
    root.setLevel(logging.INFO)
    logging.captureWarnings(True)
    try:
        yield
    finally:
        logging.captureWarnings(False)
        root.removeHandler(to_terminal)
        root.removeHandler(to_file)
        root.setLevel(level)
        to_file.close()


def _demo_app():  # type: ignore[no-untyped-def]
    """The demo's app: only on its embedded SQLite file (it writes a login it prints), with
    ``SECRET_KEY`` from the environment or a random key kept in the instance folder."""
    from app.web import embedded_database_uri
    from app.web.infra.security import stored_secret_key

    probe = offline_app()
    if probe.config["SQLALCHEMY_DATABASE_URI"] != embedded_database_uri(probe.instance_path):
        raise InputError(
            "the demo runs only on its embedded SQLite file (it creates the "
            "demo login); unset DATABASE_URL",
            field="DATABASE_URL",
        )
    if os.environ.get("SECRET_KEY"):
        return web_app()
    return web_app(SECRET_KEY=stored_secret_key(Path(probe.instance_path)))


def _jobs_child(
    study_id: int, kinds: tuple[str, ...], config: dict[str, Any], log: str | None
) -> None:
    if log is not None:
        # the progress bars, the renderer's messages and any error: into the log, at the
        # level of the file descriptors, so what C libraries print goes there too
        with open(log, "a", encoding="utf-8") as handle:
            os.dup2(handle.fileno(), 1)
            os.dup2(handle.fileno(), 2)
        logging.basicConfig(level=logging.INFO, stream=sys.stderr, format=LOG_FORMAT)
        logging.captureWarnings(True)
    app = web_app(**config)
    try:
        with app_context(app):
            run_jobs_here(study_id, kinds)
    except click.ClickException as exc:
        click.echo(f"facepair: error: {exc.message}", err=True)
        raise SystemExit(1) from None


def _run_jobs_apart(  # type: ignore[no-untyped-def]
    app, study_id: int, kinds: tuple[str, ...], log: Path | None = None
) -> None:
    """:func:`app.commands.studysetup.run_jobs_here` in a spawned process, its output into
    ``log`` when given: a process that is about to serve (and fork gunicorn workers) must never
    hold a GL context, or the forked workers hang in it."""
    import multiprocessing

    config = {
        "REQUIRE_SECRET_KEY": False,
        "SQLALCHEMY_DATABASE_URI": app.config["SQLALCHEMY_DATABASE_URI"],
        "MEDIA_ROOT": app.config["MEDIA_ROOT"],
    }
    process = multiprocessing.get_context("spawn").Process(
        target=_jobs_child,
        args=(study_id, kinds, config, None if log is None else str(log)),
        name="facepair-demo-jobs",
    )
    process.start()
    process.join()
    if process.exitcode != 0:
        why = f"{' and '.join(kinds)} of study {study_id} failed (exit code {process.exitcode})"
        if log is not None:
            errors = [
                line.removeprefix("facepair: error: ").strip()
                for line in log.read_text(encoding="utf-8", errors="replace").splitlines()
                if line.startswith("facepair: error: ")
            ]
            why += (f": {errors[-1]}" if errors else "") + f"; details in {log}"
        raise click.ClickException(why)


def _demo_login(instance: Path) -> str:
    """The demo experimenter, created or given the stored password; returns the password."""
    import sqlalchemy as sa

    from app.web.extensions import db
    from app.web.infra.accounts import change_password, create_user
    from app.web.models import User

    password = demo_password(instance)
    user = db.session.scalar(sa.select(User).where(User.email == DEMO_EMAIL))
    if user is None:
        create_user(DEMO_EMAIL, password)
    elif not user.check_password(password):  # an older demo's, or changed on the web
        change_password(user, password)
    db.session.commit()
    return password


@click.command()
@click.option("--host", default="127.0.0.1", show_default=True)
@click.option("--port", default=5000, show_default=True, type=int)
@click.option(
    "--study-file",
    type=click.Path(dir_okay=False, path_type=Path),
    default=data_path("examples", "study.toml"),
    show_default=True,
)
@click.option(
    "--log",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="The log file for everything but the links (default: demo.log in the instance folder).",
)
@click.option("--no-serve", is_flag=True, help="Set everything up, print the links, exit.")
def demo(host: str, port: int, study_file: Path, log: Path | None, no_serve: bool) -> None:
    """Migrate the embedded database, create the demo experimenter and a ready, open demo study
    (tracks generated, clips rendered from the demo speech), print the links, the login and
    the log file, then serve."""
    import sqlalchemy as sa
    from flask_migrate import upgrade

    from app.web.extensions import db
    from app.web.models import Study, User

    app = _demo_app()
    instance = Path(app.instance_path)
    log = (log or instance / LOG_NAME).absolute()
    with demo_logging(log), app_context(app):
        logging.getLogger(__name__).info("facepair demo on %s:%s", host, port)
        upgrade()
        password = _demo_login(instance)
        owner = db.session.scalar(sa.select(User.id).where(User.email == DEMO_EMAIL))
        study = db.session.scalar(
            sa.select(Study)
            .where(Study.owner_id == owner, Study.status == "open")
            .order_by(Study.id.desc())
        )
        if study is None:
            click.echo(
                "facepair demo: creating the demo study: generating its tracks and rendering "
                "its clips (a minute or more) ...",
                err=True,
            )
            study_id = create_from_file(study_file, DEMO_EMAIL)
            _run_jobs_apart(app, study_id, ("generate", "render"), log)
            study = db.session.get(Study, study_id)
            study.status = "open"  # type: ignore[union-attr]
            db.session.commit()
        slug, study_id = study.slug, study.id  # type: ignore[union-attr]
    click.echo(greeting(f"http://{host}:{port}", [slug], study_id, password, log))
    if not no_serve:
        click.echo("Serving until Ctrl+C.")
        with demo_logging(log):
            serve_app(app, host, port, workers=1, dev=False, log=log)
