"""Flask extensions, created unbound and initialised in the factory (Flask "Application
Factories"); models import ``db`` from here, never from the package ``__init__``."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import sqlalchemy as sa
from flask_limiter import Limiter
from flask_limiter.util import get_remote_address
from flask_migrate import Migrate
from flask_sqlalchemy import SQLAlchemy
from flask_wtf import CSRFProtect
from sqlalchemy import orm as so

if TYPE_CHECKING:
    from flask import Flask

#: Named constraints, so that SQLite batch migrations never meet an unnamed one.
NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}


class Base(so.DeclarativeBase):
    metadata = sa.MetaData(naming_convention=NAMING_CONVENTION)


#: Alembic scripts ship inside the package, so an installed wheel migrates too
#: (``facepair db upgrade`` in a checkout, ``facepair demo``).
MIGRATIONS = Path(__file__).resolve().parent / "migrations"

db = SQLAlchemy(model_class=Base)
migrate = Migrate()
csrf = CSRFProtect()
#: Login attempts per account and per address (``app.web.infra.security``); storage set in the
#: factory.
limiter = Limiter(key_func=get_remote_address)


def init_extensions(app: Flask) -> None:
    db.init_app(app)
    migrate.init_app(app, db, directory=str(MIGRATIONS), render_as_batch=True)
    csrf.init_app(app)


@contextmanager
def transaction() -> Iterator[so.Session]:
    """One unit of work outside a request (workers, CLI): commit on success, else roll back.

    Views do not use it: a request is its own unit of work (commit in the view; the session is
    rolled back and removed at teardown).
    """
    session = db.session
    try:
        yield session
        session.commit()
    except BaseException:
        session.rollback()
        raise
