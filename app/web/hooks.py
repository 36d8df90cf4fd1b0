"""Wiring of the web layer: models, blueprints, per-request unit of work, SQLite pragmas, and
bounded input (``app.web.infra.limits``): a value no column can hold is a 400 naming the field, an
identifier in a URL that no row can have is a 404, never a database error."""

from __future__ import annotations

import time
import weakref
from typing import TYPE_CHECKING, Any

import sqlalchemy as sa
from flask import abort, current_app, jsonify, redirect, render_template, request, url_for
from werkzeug.exceptions import HTTPException

from app.errors import InputError
from app.trials.design import RATING_DESIGNS
from app.web.api import bp as api_bp
from app.web.experimenter import bp as experimenter_bp
from app.web.extensions import csrf, db
from app.web.infra import limits
from app.web.infra.limits import INT32, text_problem
from app.web.leaderboard import bp as leaderboard_bp
from app.web.participant import bp as participant_bp
from app.web.questionnaire import bp as questionnaire_bp
from app.web.questionnaire.views import questionnaire_first
from app.web.serving import record_route
from app.web.study.recruitment import REDIRECT_SECONDS, participant_completion_url

if TYPE_CHECKING:
    from flask import Flask


def _sqlite_pragmas(dbapi_connection, _record) -> None:  # type: ignore[no-untyped-def]
    # Foreign keys are off by default in SQLite; WAL lets readers run beside the one writer.
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.execute("PRAGMA busy_timeout=30000")
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.close()


#: A pooled connection unused for longer than this is pinged before it is handed out.
PING_AFTER_IDLE_SECONDS = 1.0
_PINGED: weakref.WeakSet[sa.Engine] = weakref.WeakSet()


def ping_idle_connections(engine: sa.Engine) -> None:
    """Ping a connection before a checkout only if it sat in the pool for over
    :data:`PING_AFTER_IDLE_SECONDS`; a dead one is replaced, unseen by the request.

    A database restart takes longer than that, so the first request after one still gets a
    live connection, as with the pool's ``pre_ping``; but a busy server, whose connections go
    straight back out, no longer pays a round trip per checkout. A connection that breaks
    while in use (the database stopped mid-request) invalidates the pool and answers 503
    with Retry-After
    (:func:`_database_unavailable`), as before.
    """

    def checked_in(_dbapi_connection: Any, record: Any) -> None:
        record.info["checked_in"] = time.monotonic()

    def checkout(dbapi_connection: Any, record: Any, _proxy: Any) -> None:
        since = record.info.get("checked_in")
        if since is None or time.monotonic() - since < PING_AFTER_IDLE_SECONDS:
            return  # new, or just back from another request
        try:
            engine.dialect.do_ping(dbapi_connection)
        except engine.dialect.loaded_dbapi.Error as exc:
            raise sa.exc.DisconnectionError(str(exc)) from exc

    if engine not in _PINGED:
        _PINGED.add(engine)
        sa.event.listen(engine, "checkin", checked_in)
        sa.event.listen(engine, "checkout", checkout)


def _identifier_fits(value: object) -> bool:

    if isinstance(value, int):
        return INT32[0] <= value <= INT32[1]
    return not isinstance(value, str) or text_problem(value, 500) is None


def _bad_input(exc: InputError):  # type: ignore[no-untyped-def]

    db.session.rollback()
    if _wants_json():
        return jsonify({"error": str(exc)}), 400
    return render_template("error.html", message=str(exc), status=400), 400


def _wants_json() -> bool:

    return request.blueprint == "api" or request.accept_mimetypes.best == "application/json"


def _database_unavailable(exc: Exception):  # type: ignore[no-untyped-def]
    """The database cannot be reached (or is restarting): 503 with Retry-After, so the
    participant's browser keeps the vote and sends it again, instead of a 500."""

    current_app.logger.warning("database unavailable: %s", str(exc).splitlines()[0])
    try:
        db.session.rollback()
    except sa.exc.SQLAlchemyError:
        pass  # the connection is already gone; the session is removed at teardown
    message = "the database is unavailable for a moment; please try again"
    seconds = str(current_app.config["RETRY_AFTER_SECONDS"])
    if _wants_json():
        response = jsonify({"error": message})
    else:
        response = current_app.make_response(
            render_template("error.html", message=message, status=503)
        )
    response.status_code = 503
    response.headers["Retry-After"] = seconds
    return response


#: What the error page's heading says of a client error (the page under it says why).
CLIENT_ERRORS = {
    400: "This request could not be used",
    403: "You may not open this page",
    404: "Nothing is here",
    405: "This page cannot be used this way",
}


def _client_error(exc: HTTPException):  # type: ignore[no-untyped-def]
    """A 4xx raised by routing or ``abort`` as the site's own page (a main landmark, the
    site's styles, one plain sentence) instead of the framework's bare HTML; JSON clients get
    the framework's answer as before."""
    if _wants_json() or exc.code not in CLIENT_ERRORS:
        return exc
    page = render_template(
        "error.html", status=exc.code, heading=CLIENT_ERRORS[exc.code], message=exc.description
    )
    response = current_app.make_response((page, exc.code))
    for name, value in exc.get_headers():
        if name.lower() != "content-type":
            response.headers[name] = value
    return response


def init_web(app: Flask) -> None:

    app.register_blueprint(participant_bp)
    app.register_blueprint(questionnaire_bp)
    # The participant's path passes through the study's questionnaire pages by itself.
    app.before_request(questionnaire_first)
    app.register_blueprint(experimenter_bp)
    app.register_blueprint(api_bp)
    app.register_blueprint(leaderboard_bp)
    # The JSON API authenticates participants by the token in the request body, not a cookie,
    # so a cross-site form cannot forge a vote; experimenter endpoints there are GET only.
    csrf.exempt(api_bp)

    # The completion page sends a finished participant on (``app.web.study.recruitment``).
    app.jinja_env.globals.update(
        participant_completion_url=participant_completion_url, redirect_seconds=REDIRECT_SECONDS
    )
    # Which designs answer by ratings (their exports and pages differ from the pair designs').
    app.jinja_env.globals["rating_designs"] = RATING_DESIGNS

    limits.install(db.session)

    @app.after_request
    def _route_for_the_access_log(response):  # type: ignore[no-untyped-def]
        # The route's template, not the path: the access log names nobody (app.web.serving).
        record_route(request.environ, request.url_rule.rule if request.url_rule else None)
        return response

    app.register_error_handler(InputError, _bad_input)
    app.register_error_handler(HTTPException, _client_error)
    # Connection refused, a server restarting, a pool that cannot hand out a connection.
    for error in (sa.exc.OperationalError, sa.exc.InterfaceError, sa.exc.TimeoutError):
        app.register_error_handler(error, _database_unavailable)

    @app.url_value_preprocessor
    def _identifiers_must_fit(_endpoint: str | None, values: dict | None) -> None:
        # Tokens, slugs and ids in URLs name rows: one no column can hold names nothing.
        if values and not all(_identifier_fits(v) for v in values.values()):
            abort(404)

    with app.app_context():
        if not app.config["SQLALCHEMY_ENGINE_OPTIONS"].get("pool_pre_ping"):
            ping_idle_connections(db.engine)
        if app.config["SQLALCHEMY_DATABASE_URI"].startswith("sqlite"):
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

        return redirect(url_for("experimenter.studies"))
