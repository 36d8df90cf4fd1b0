"""The ``facepair`` command line pointed at a test's application, for the tests that run its
commands (``tests/commands/``, ``tests/web/``). Nothing here is part of the application."""

from __future__ import annotations


def cli_env(monkeypatch, app):
    """Point the commands at ``app``'s database and media folder, through the environment as a
    deployment does."""
    monkeypatch.setenv("DATABASE_URL", app.config["SQLALCHEMY_DATABASE_URI"])
    monkeypatch.setenv("MEDIA_ROOT", app.config["MEDIA_ROOT"])
