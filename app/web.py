"""Wiring of the web layer: models, blueprints, per-request unit of work, SQLite pragmas."""

from __future__ import annotations

from typing import TYPE_CHECKING

import sqlalchemy as sa

if TYPE_CHECKING:
    from flask import Flask


def _sqlite_pragmas(dbapi_connection, _record) -> None:  # type: ignore[no-untyped-def]
    # Foreign keys are off by default in SQLite; WAL lets readers run beside the one writer.
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.execute("PRAGMA busy_timeout=30000")
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.close()


def init_web(app: Flask) -> None:
    from app import models  # noqa: F401  (the models register on db.metadata)
    from app.api.views import bp as api_bp
    from app.experimenter.views import bp as experimenter_bp
    from app.extensions import csrf, db
    from app.participant.views import bp as participant_bp

    app.register_blueprint(participant_bp)
    app.register_blueprint(experimenter_bp)
    app.register_blueprint(api_bp)
    # The JSON API authenticates participants by the token in the request body, not a cookie,
    # so a cross-site form cannot forge a vote; experimenter endpoints there are GET only.
    csrf.exempt(api_bp)

    if app.config["SQLALCHEMY_DATABASE_URI"].startswith("sqlite"):
        with app.app_context():
            sa.event.listen(db.engine, "connect", _sqlite_pragmas)

    @app.teardown_request
    def _rollback_on_error(exc: BaseException | None) -> None:
        if exc is not None:
            db.session.rollback()

    @app.get("/healthz")
    def healthz():  # type: ignore[no-untyped-def]
        db.session.execute(sa.text("SELECT 1"))
        return {"status": "ok"}

    @app.get("/")
    def index():  # type: ignore[no-untyped-def]
        from flask import redirect, url_for

        return redirect(url_for("experimenter.studies"))
