"""Statements straight to psycopg (``app.driver``): compiled once, rows named by their labels,
a transaction that commits only when asked, driver errors as SQLAlchemy's."""

import datetime as dt

import psycopg
import pytest
import sqlalchemy as sa

from app import driver
from app.extensions import db
from app.models import Study, User


@pytest.fixture
def pg_app(app):
    with app.app_context():
        if not driver.available():
            pytest.skip("the driver's path is PostgreSQL's")
    return app


def _emails(app):
    with app.app_context():
        return db.session.scalars(sa.select(User.email).order_by(User.id)).all()


# Every value given: the driver applies no column defaults computed in Python.
INSERT = (
    sa.insert(User)
    .values(email=sa.bindparam("email"), password_hash="x", created_at=sa.bindparam("at"))
    .returning(User.id, User.email)
)
AT = dt.datetime(2026, 1, 1)


def test_compiled_once_with_its_literals_and_its_labels(pg_app):
    statement = sa.select(Study.id.label("study_id"), sa.literal(7).label("seven"))
    with pg_app.app_context():
        first = driver.compiled(statement)
        assert driver.compiled(statement) is first  # cached
        assert "$1" in first.sql and "%(" not in first.sql  # PostgreSQL's own placeholders
        assert first.row._fields == ("study_id", "seven")
        assert 7 in first.defaults.values()  # a literal the statement binds itself
        assert driver.compiled(sa.update(Study).values(title="x")).row is None


def test_a_missing_value_is_an_error_and_types_process_their_values(pg_app):
    with pg_app.app_context():
        found = driver.compiled(INSERT)
        with pytest.raises(sa.exc.ArgumentError, match="no value for at, email"):
            found.params({})
        as_json = sa.select(sa.bindparam("doc", type_=sa.JSON).label("doc"))
        assert driver.compiled(as_json).params({"doc": None})[0] is not None  # JSON null
        # A value bound twice is one parameter, in the order the SQL numbers them.
        twice = sa.select(
            (sa.bindparam("a", type_=sa.Integer) - sa.bindparam("b", type_=sa.Integer)).label("d"),
            (sa.bindparam("b", type_=sa.Integer) * 10).label("e"),
        )
        found = driver.compiled(twice)
        assert found.order[:2] == ("a", "b") and found.params({"b": 2, "a": 7}) == [7, 2, 10]
        with driver.transaction() as tx:
            assert tx.run(twice, {"a": 7, "b": 2}) == (5, 20)
        with driver.transaction() as tx:
            assert tx.run(as_json, {"doc": {"a": [1, 2]}}).doc == {"a": [1, 2]}


def test_a_transaction_commits_only_when_asked(pg_app):
    with pg_app.app_context():
        with driver.transaction() as tx:
            row = tx.run(INSERT, {"email": "kept@example.org", "at": AT})
            assert row.email == "kept@example.org" and row.id > 0
            tx.commit()
        with driver.transaction() as tx:
            tx.run(INSERT, {"email": "early@example.org", "at": AT})  # no commit: rolled back
        with pytest.raises(RuntimeError), driver.transaction() as tx:
            tx.run(INSERT, {"email": "raised@example.org", "at": AT})
            raise RuntimeError("a bug in the caller")
    assert _emails(pg_app) == ["kept@example.org"]


def test_a_driver_error_is_sqlalchemys_and_a_broken_connection_leaves_the_pool(pg_app):
    with pg_app.app_context():
        # A constraint the database enforces: as SQLAlchemy's IntegrityError.
        with pytest.raises(sa.exc.IntegrityError), driver.transaction() as tx:
            tx.run(INSERT, {"email": "twice@example.org", "at": AT})
            tx.run(INSERT, {"email": "twice@example.org", "at": AT})  # unique
        # A lost connection: OperationalError (answered 503), and the connection is dropped.
        with pytest.raises(sa.exc.OperationalError), driver.transaction() as tx:
            pid = tx.run(sa.select(sa.func.pg_backend_pid().label("pid")), {}).pid
            with psycopg.connect(
                db.engine.url.set(drivername="postgresql").render_as_string(False),
                autocommit=True,
            ) as admin:
                admin.execute("SELECT pg_terminate_backend(%s)", (pid,))
            tx.run(INSERT, {"email": "lost@example.org", "at": AT})
        with driver.transaction() as tx:  # a live connection again
            assert tx.run(sa.select(sa.func.pg_backend_pid().label("pid")), {}).pid != pid
    assert _emails(pg_app) == []


def test_on_session_runs_the_same_statements_in_the_sessions_transaction(app):
    with app.app_context():
        row = driver.on_session(INSERT, {"email": "session@example.org", "at": AT})
        assert row.email == "session@example.org"
        assert driver.on_session(sa.update(Study).values(title="renamed"), {}) is None
        db.session.rollback()
    assert _emails(app) == []


def test_a_pooled_connection_keeps_one_cursor_and_a_new_connection_makes_its_own(pg_app):
    pid = sa.select(sa.func.pg_backend_pid().label("pid"))
    with pg_app.app_context():
        with driver.transaction() as tx:
            first, backend = tx.cursor, tx.run(pid, {}).pid
        with driver.transaction() as tx:  # the same pooled connection, the same cursor
            assert tx.run(pid, {}).pid == backend and tx.cursor is first
        db.engine.dispose()  # the pool's connections closed: their cursors go with them
        with driver.transaction() as tx:
            assert tx.cursor is not first and tx.run(pid, {}).pid != backend


def test_an_autocommitted_statement_stands_and_its_connection_goes_back_in_a_transaction(
    pg_app,
):
    pid = sa.select(sa.func.pg_backend_pid().label("pid"))
    with pg_app.app_context():
        row = driver.autocommitted(INSERT, {"email": "alone@example.org", "at": AT})
        assert row.email == "alone@example.org"
        # Committed by itself: another connection sees it before anything else runs here.
        assert _emails(pg_app) == ["alone@example.org"]
        assert driver.autocommitted(sa.update(Study).values(title="x"), {}) is None
        backend = driver.autocommitted(pid, {}).pid
        with driver.transaction() as tx:  # the same pooled connection, out of autocommit
            assert tx.run(pid, {}).pid == backend
            assert tx.raw.driver_connection.autocommit is False
            tx.run(INSERT, {"email": "rolled-back@example.org", "at": AT})  # not committed
        # A failed statement: SQLAlchemy's error, and the connection back out of autocommit.
        with pytest.raises(sa.exc.IntegrityError):
            driver.autocommitted(INSERT, {"email": "alone@example.org", "at": AT})
        with db.engine.connect() as conn:  # the session's side of the same pool
            assert conn.connection.driver_connection.autocommit is False
    assert _emails(pg_app) == ["alone@example.org"]


def test_a_lost_connection_under_an_autocommitted_statement_leaves_the_pool(pg_app):
    pid = sa.select(sa.func.pg_backend_pid().label("pid"))
    with pg_app.app_context():
        backend = driver.autocommitted(pid, {}).pid
        with psycopg.connect(
            db.engine.url.set(drivername="postgresql").render_as_string(False), autocommit=True
        ) as admin:
            admin.execute("SELECT pg_terminate_backend(%s)", (backend,))
        with pytest.raises(sa.exc.OperationalError):
            driver.autocommitted(INSERT, {"email": "lost@example.org", "at": AT})
        assert driver.autocommitted(pid, {}).pid != backend  # a live connection again
    assert _emails(pg_app) == []


def test_a_percent_sign_reaches_postgresql_as_it_is(pg_app):
    statement = sa.select(
        (sa.bindparam("a", type_=sa.Integer) % 3).label("rest"),
        sa.literal_column("'5%'").label("share"),
    )
    with pg_app.app_context():
        assert "%%" not in driver.compiled(statement).sql
        assert driver.autocommitted(statement, {"a": 7}) == (1, "5%")
        with driver.transaction() as tx:
            assert tx.run(statement, {"a": 8}) == (2, "5%")


def test_an_autocommitted_statement_that_fails_to_compile_gives_its_connection_back(
    pg_app, monkeypatch
):
    def broken(statement, dialect):
        raise sa.exc.CompileError("a statement the dialect cannot write")

    with pg_app.app_context():
        monkeypatch.setattr(driver, "_compiled", broken)
        with pytest.raises(sa.exc.CompileError):
            driver.autocommitted(INSERT, {"email": "never@example.org", "at": AT})
        assert db.engine.pool.checkedout() == 0
        monkeypatch.undo()
        assert driver.autocommitted(INSERT, {"email": "after@example.org", "at": AT}) is not None
    assert _emails(pg_app) == ["after@example.org"]
