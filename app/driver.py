"""The participant's hottest statements straight to psycopg, on the engine's pooled connections.

Every trial asks for a play (``POST /api/v1/plays``) and casts a vote (``POST /api/v1/votes``).
In the load benchmark's profile the ORM session around those few statements (creating it,
checking out its connection, committing, removing it) and SQLAlchemy's execution of each
statement cost more CPU than the statements themselves: in process, a vote's two statements
took 0.8 ms through the session and 0.4 ms on the driver. Here the statements stay SQLAlchemy
Core statements, defined once in the modules that use them, compiled once for the engine's
dialect (:func:`compiled`) and run on a connection from the same pool, so the pool's events
(the idle ping of :func:`app.web.ping_idle_connections`), its size and its reset on return all
apply.

:func:`transaction` gives one transaction on such a connection. It commits only when asked;
anything else rolls back. :func:`autocommitted` runs one statement as its own transaction, in
one round trip. A driver error comes out as SQLAlchemy's (a lost connection is a
:class:`sqlalchemy.exc.OperationalError`, which ``app.web`` answers with 503), and a connection
that failed is dropped from the pool, not handed out again. PostgreSQL only: on SQLite the same
statements go through the session (:func:`on_session`). Bind processors apply as on
SQLAlchemy's path; column defaults computed in Python do not: a statement passes every value.
"""

from __future__ import annotations

import copy
from collections import namedtuple
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from functools import cache
from typing import Any, NamedTuple, NoReturn

import psycopg
import sqlalchemy as sa

from app.extensions import db


class DriverSQL(NamedTuple):
    """A Core statement compiled for the driver, with PostgreSQL's own placeholders (``$1``):
    its SQL, the names of its parameters in their order, their defaults (the literals a
    statement binds, such as ``kind <> 'practice'``), the names it needs a value for, the bind
    processors of its types (a JSON column's, say) and the class of the rows it returns (named
    by its column labels), None if it returns none."""

    sql: str
    order: tuple[str, ...]
    defaults: dict[str, Any]
    required: frozenset[str]
    processors: dict[str, Any]
    row: Any

    def params(self, values: Mapping[str, Any]) -> list[Any]:
        """The driver's parameters, in order: ``values`` over the defaults, each through its
        type's bind processor as on SQLAlchemy's own path (a JSON column's None is JSON
        ``null`` there, not SQL NULL). A value the statement needs and ``values`` lacks is an
        error, as there, not a NULL."""
        missing = self.required.difference(values)
        if missing:
            raise sa.exc.ArgumentError(f"no value for {', '.join(sorted(missing))}")
        params = {**self.defaults, **values}
        for name, process in self.processors.items():
            params[name] = process(params[name])
        return [params[name] for name in self.order]


@cache
def _numbered(dialect: sa.Dialect) -> sa.Dialect:
    """``dialect`` writing PostgreSQL's numbered placeholders (``$1``), which a
    :class:`psycopg.RawCursor` sends as they are: psycopg parses a query's ``%(name)s``
    placeholders on every execution once the query is over 4 KB (it caches shorter ones),
    which was a third of the vote view's CPU in the load benchmark's profile once the vote was
    one statement of 5 KB. A copy, so that everything else the engine's dialect learnt of the
    server compiles the same, with a preparer of its own (the engine's doubles every ``%`` for
    psycopg's placeholders, which a raw cursor would send doubled)."""
    numbered = copy.copy(dialect)
    numbered.paramstyle = "numeric_dollar"
    numbered.positional = True
    numbered.identifier_preparer = numbered.preparer(numbered)
    return numbered


@cache
def _compiled(statement: Any, dialect: sa.Dialect) -> DriverSQL:
    found = statement.compile(dialect=_numbered(dialect))
    # A SELECT's columns, or an UPDATE's RETURNING: known here, so a row is made without the
    # driver describing each result (its description was a tenth of a vote in the profile).
    labels = list(statement.exported_columns.keys())
    row = namedtuple("Row", labels) if labels else None  # type: ignore[misc]
    required = frozenset(name for name, bind in found.binds.items() if bind.required)
    processors = {}
    for name, bind in found.binds.items():
        process = bind.type.dialect_impl(dialect).bind_processor(dialect)
        if process is not None:
            processors[name] = process
    order = tuple(found.positiontup or ())
    return DriverSQL(str(found), order, dict(found.params), required, processors, row)


def compiled(statement: Any) -> DriverSQL:
    """``statement`` (built once by its module, so the cache here holds each once) compiled
    for the engine's dialect, once."""
    return _compiled(statement, db.engine.dialect)


def available() -> bool:
    """Whether the engine's driver is psycopg (PostgreSQL)."""
    return db.engine.dialect.driver == "psycopg"


def on_session(statement: Any, values: Mapping[str, Any]) -> Any:
    """What :meth:`Transaction.run` does, through the request's session instead (SQLite):
    the row ``statement`` returns, if any, in the session's transaction."""
    result = db.session.connection().execute(statement, values)
    return result.one_or_none() if result.returns_rows else None


def execute(cursor: Any, statement: DriverSQL, values: Mapping[str, Any]) -> Any:
    """Run ``statement`` on a driver cursor; the row it returns, if any, with the statement's
    column labels as attributes. Every statement of this module's transactions goes through
    here."""
    cursor.execute(statement.sql, statement.params(values))
    if statement.row is None:
        return None
    found = cursor.fetchone()
    return None if found is None else statement.row._make(found)


def _cursor(raw: Any) -> Any:
    """A raw cursor (numbered placeholders: :func:`_numbered`) on the pooled connection
    ``raw``, made once per driver connection and kept in the pool's record of it (creating one
    was a fiftieth of a vote's CPU in the load benchmark's profile); the record's ``info`` is
    cleared when its connection is closed or invalidated, so a new connection makes its own."""
    kept = raw.info.get("driver_cursor")
    if kept is None:
        kept = raw.info["driver_cursor"] = psycopg.RawCursor(raw.driver_connection)
    return kept


class Transaction:
    """One transaction on a pooled driver connection (see :func:`transaction`)."""

    def __init__(self, raw: Any, dialect: sa.Dialect) -> None:
        self.raw = raw
        self.dialect = dialect
        self.cursor = _cursor(raw)
        self.committed = False
        self.last = ""

    def run(self, statement: Any, values: Mapping[str, Any]) -> Any:
        """Run a Core ``statement`` (compiled once); the row it returns, if any."""
        found = _compiled(statement, self.dialect)
        self.last = found.sql
        return execute(self.cursor, found, values)

    def commit(self) -> None:
        self.raw.commit()
        self.committed = True


def _as_sqlalchemy(exc: psycopg.Error, statement: str | None) -> sa.exc.DBAPIError:
    return sa.exc.DBAPIError.instance(
        statement, None, exc, psycopg.Error, dialect=db.engine.dialect
    )


def _failed(
    engine: sa.Engine, raw: Any, exc: BaseException, cursor: Any, sql: str | None
) -> NoReturn:
    """Raise for a failed use of the pooled connection ``raw``: a driver error as
    SQLAlchemy's, the connection invalidated if lost; anything else as it is, the connection
    invalidated if interrupted (perhaps mid-statement)."""
    if isinstance(exc, psycopg.Error):
        if engine.dialect.is_disconnect(exc, raw.dbapi_connection, cursor):
            # Lost: never handed out again (the pool's other connections are pinged once
            # idle for a second; one used sooner answers 503 once, and the vote is resent).
            raw.invalidate(exc)
        raise _as_sqlalchemy(exc, sql) from exc
    if not isinstance(exc, Exception):
        raw.invalidate(exc)
    raise exc


def autocommitted(statement: Any, values: Mapping[str, Any]) -> Any:
    """Run the Core ``statement`` alone, in autocommit (its own transaction, committed by
    PostgreSQL when it ends), on a connection from the engine's pool: the row it returns, if
    any. One round trip where :func:`transaction` takes three (BEGIN, the statement,
    COMMIT), which in a bare psycopg loop took a quarter of a vote's PostgreSQL CPU; for a
    statement whose every outcome may stand committed. The connection goes back to the pool
    out of autocommit, or is dropped."""
    engine = db.engine
    try:
        raw = engine.raw_connection()
    except psycopg.Error as exc:
        raise _as_sqlalchemy(exc, None) from exc
    conn = raw.driver_connection
    found = cursor = None
    try:
        found = _compiled(statement, engine.dialect)
        conn.autocommit = True
        cursor = _cursor(raw)
        return execute(cursor, found, values)
    except BaseException as exc:
        _failed(engine, raw, exc, cursor, found.sql if found else None)
    finally:
        if raw.dbapi_connection is not None and conn.autocommit:
            try:
                conn.autocommit = False
            except psycopg.Error:
                raw.invalidate()
        raw.close()


@contextmanager
def transaction() -> Iterator[Transaction]:
    """A transaction on a connection from the engine's pool: committed by
    :meth:`Transaction.commit`, rolled back otherwise (an early return, an exception)."""
    engine = db.engine  # looked up once: Flask-SQLAlchemy finds it by the current app
    try:
        raw = engine.raw_connection()
    except psycopg.Error as exc:  # no connection to be had
        raise _as_sqlalchemy(exc, None) from exc
    tx = None
    try:
        tx = Transaction(raw, engine.dialect)
        yield tx
    except BaseException as exc:
        _failed(engine, raw, exc, tx.cursor if tx else None, tx.last if tx else None)
    finally:
        if (tx is None or not tx.committed) and raw.dbapi_connection is not None:
            try:
                raw.rollback()
            except psycopg.Error:
                raw.invalidate()
        raw.close()
