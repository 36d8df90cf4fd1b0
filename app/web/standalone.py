"""The web application in a process that answers no web request: a ``facepair`` command, an RQ
job in its work horse, a spawned job process.

Each starts the same way: the application built from the environment without a deployment key
(:func:`offline_app`: such a process signs no session), then entered with its database
connections closed on the way out (:func:`app_context`), so that it ends, or forks its next
work horse, holding none.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from app.web import create_app
from app.web.extensions import db

if TYPE_CHECKING:
    from flask import Flask


def offline_app(config: Mapping[str, Any] | None = None) -> Flask:
    """The application from the environment and ``config``, with no deployment key required."""
    return create_app({**(config or {}), "REQUIRE_SECRET_KEY": False})


@contextmanager
def app_context(app: Flask) -> Iterator[Flask]:
    """``app``'s application context, its database connections closed on the way out."""
    with app.app_context():
        try:
            yield app
        finally:
            db.session.remove()
            db.engine.dispose()
