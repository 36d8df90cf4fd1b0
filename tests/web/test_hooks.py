"""The web wiring (``app.web.hooks``): a pooled connection the database dropped while it sat idle
is replaced before a request gets it, without a ping on every checkout."""

import pytest
import sqlalchemy as sa

from app.web import hooks as web
from app.web.extensions import db


def _backend_pid(app) -> int:
    with app.app_context():
        pid = db.session.execute(sa.text("SELECT pg_backend_pid()")).scalar_one()
        db.session.remove()  # the connection goes back to the pool
    return int(pid)


def _terminate(app, pid: int) -> None:
    """What a database restart does to a pooled connection: its server process ends."""
    with app.app_context():
        other = sa.create_engine(app.config["SQLALCHEMY_DATABASE_URI"])
        with other.connect() as conn:
            conn.execute(sa.text("SELECT pg_terminate_backend(:pid)"), {"pid": pid})
        other.dispose()


@pytest.mark.postgres
def test_a_connection_dropped_while_idle_is_replaced_unseen(app, client, monkeypatch):
    if not app.config["SQLALCHEMY_DATABASE_URI"].startswith("postgresql"):
        pytest.skip("a server process to terminate")
    monkeypatch.setattr(web, "PING_AFTER_IDLE_SECONDS", 0.0)
    first = _backend_pid(app)
    _terminate(app, first)
    assert client.get("/healthz").status_code == 200
    assert _backend_pid(app) != first


@pytest.mark.postgres
def test_a_busy_connection_is_not_pinged_and_a_dropped_one_answers_503(app, client, monkeypatch):
    if not app.config["SQLALCHEMY_DATABASE_URI"].startswith("postgresql"):
        pytest.skip("a server process to terminate")
    monkeypatch.setattr(web, "PING_AFTER_IDLE_SECONDS", 3600.0)
    pings = []
    with app.app_context():
        monkeypatch.setattr(db.engine.dialect, "do_ping", lambda c: pings.append(c) or True)
    first = _backend_pid(app)
    assert client.get("/healthz").status_code == 200 and pings == []
    _terminate(app, first)
    # Dropped between two requests within the idle time: a clean 503 the browser retries...
    answer = client.get("/healthz")
    assert answer.status_code == 503 and answer.headers["Retry-After"]
    # ...and the pool was renewed by it.
    assert client.get("/healthz").status_code == 200
