"""``facepair db upgrade`` and ``facepair db current``: the schema through the migrations.

The schema exists only through the migrations (``app/web/migrations``, Flask-Migrate/Alembic),
never ``create_all``. Every command that reads the database first asks :func:`migrated`, so an
empty or outdated database is one line naming the fix, not a traceback.
"""

from __future__ import annotations

import click

from app.commands.webapp import app_context, offline_app
from app.errors import InputError


def revisions() -> tuple[str | None, str]:
    """(the database's revision or None, the migrations' head), in an application context."""
    from alembic.runtime.migration import MigrationContext
    from alembic.script import ScriptDirectory
    from flask import current_app

    from app.web.extensions import MIGRATIONS, db

    script = ScriptDirectory(str(MIGRATIONS))
    with db.engine.connect() as connection:
        current = MigrationContext.configure(connection).get_current_revision()
    head = script.get_current_head()
    assert head is not None, current_app.name  # the project ships its migrations
    return current, head


def migrated() -> None:
    """Refuse to go on, in one line, unless the database is at the migrations' head."""
    current, head = revisions()
    if current is None:
        raise InputError("the database has no schema yet: run 'facepair db upgrade'")
    if current != head:
        raise InputError(
            f"the database is at revision {current}, the code needs {head}: "
            "run 'facepair db upgrade'"
        )


@click.group()
def db() -> None:
    """The database schema (DATABASE_URL, else SQLite in the instance folder)."""


@db.command("upgrade")
def upgrade() -> None:
    """Bring the schema up to date (runs every migration not yet applied)."""
    from flask_migrate import upgrade as flask_upgrade

    with app_context(offline_app()):
        before, head = revisions()
        flask_upgrade()
        click.echo(
            f"database at {head}" + ("" if before == head else f" (was {before or 'empty'})")
        )


@db.command("current")
def current() -> None:
    """Print the database's schema revision and whether it is the code's."""
    with app_context(offline_app()):
        revision, head = revisions()
    if revision is None:
        click.echo(f"no schema yet (the code's is {head}): run 'facepair db upgrade'")
    elif revision == head:
        click.echo(f"{revision} (up to date)")
    else:
        click.echo(f"{revision} (the code's is {head}: run 'facepair db upgrade')")
