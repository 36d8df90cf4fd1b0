"""The ``facepair`` command line: one click group with a subcommand group per job.

A user error (:class:`app.errors.InputError`) exits with code 2 and one line on stderr, never
a traceback.
"""

from __future__ import annotations

import sys

import click

from app import __version__
from app.errors import InputError


class FacepairGroup(click.Group):
    """Turns bad input anywhere below into one line and exit code 2."""

    def invoke(self, ctx: click.Context):  # type: ignore[override]
        try:
            return super().invoke(ctx)
        except InputError as exc:
            click.echo(f"facepair: error: {exc}", err=True)
            sys.exit(2)
        except Exception as exc:
            line = database_problem(exc)
            if line is None:
                raise
            click.echo(f"facepair: error: {line}", err=True)
            sys.exit(2)


def database_problem(exc: BaseException) -> str | None:
    """One line for a database that is not ready (no schema, an older one, unreachable), or
    None for any other error (which keeps its traceback: a bug)."""
    if type(exc).__module__ != "sqlalchemy.exc":
        return None
    text = str(getattr(exc, "orig", exc)).lower()
    if (
        "no such table" in text
        or "no such column" in text
        or ("does not exist" in text and ("relation" in text or "column" in text))
    ):
        return "the database has no schema or an older one: run 'facepair db upgrade'"
    if type(exc).__name__ == "OperationalError" and (
        "connect" in text or "connection" in text or "unable to open" in text
    ):
        first = text.strip().splitlines()[0] if text.strip() else type(exc).__name__
        return f"the database (DATABASE_URL) cannot be reached: {first}"
    return None


@click.group(cls=FacepairGroup)
@click.version_option(__version__, prog_name="facepair")
def main() -> None:
    """facepair: paired-comparison studies of talking-face animation."""


def _register() -> None:
    from app.commands import (
        analyze,
        capture,
        face,
        leaderboard,
        plan,
        prolific,
        render,
        stimuli,
        studies,
        web,
    )

    main.add_command(stimuli.stimuli)
    main.add_command(capture.capture)
    main.add_command(render.render)
    main.add_command(face.face)
    main.add_command(analyze.analyze)
    main.add_command(plan.plan)
    web.register(main)
    studies.register(main)
    prolific.register(main)
    leaderboard.register(main)


_register()
