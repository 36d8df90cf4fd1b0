"""How gunicorn serves the app: timeouts, request limits and an access log that names nobody.

One place for the production server's settings, used by ``facepair serve`` (and ``facepair
demo``) and by the container (``gunicorn -c python:app.web.serving 'app.web:create_app()'``):
gunicorn reads this module's lower-case names that are its settings and ignores the rest.

**The access log.** gunicorn's default line holds the client's address, the path (a
participant's token is in it: ``/p/<token>/trial``), the query (Prolific's ``PROLIFIC_PID``) and
the referrer (a URL with the token again). Kept in a log, those would outlive a participant's
request to delete their data (docs/operations.md, "Logs"). :class:`PrivateAccessLogger` writes
the route's template instead (``GET /p/<token>/trial 200``, from the Flask URL rule the app
records in the request's WSGI environ, :func:`record_route`), no address, query, referrer or
user agent; a request no route matched is logged as ``<unmatched>``.

**No control socket.** gunicorn 25.1 and later open a control socket for ``gunicornc``
(reload, stop, change the worker count) at ``$XDG_RUNTIME_DIR/gunicorn.ctl`` or
``~/.gunicorn/gunicorn.ctl``: one path for every gunicorn of a user on the host, so a second
``facepair serve`` took the first one's socket, and whichever stopped first removed the
other's. It is turned off (``control_socket_disable``); signals do the same work (HUP reloads,
TERM stops, TTIN and TTOU add and remove a worker).
"""

from __future__ import annotations

import logging
import os
from typing import Any

from gunicorn.config import KNOWN_SETTINGS
from gunicorn.glogging import Logger

#: The WSGI environ key where the app leaves the matched route's template for the log.
ROUTE_KEY = "facepair.route"
#: The line: time, the request with the route template, status, bytes, milliseconds.
ACCESS_LOG_FORMAT = '%(t)s "%(r)s" %(s)s %(b)s %(M)sms'

log = logging.getLogger(__name__)


def record_route(environ: dict[str, Any], rule: str | None) -> None:
    """Leave the matched URL rule (``/p/<token>/trial``) where the access log finds it."""
    environ[ROUTE_KEY] = rule or "<unmatched>"


class PrivateAccessLogger(Logger):  # type: ignore[misc]
    """gunicorn's logger with every identifying atom of the access line blanked."""

    def atoms(self, resp: Any, req: Any, environ: dict[str, Any], request_time: Any) -> Any:
        atoms = super().atoms(resp, req, environ, request_time)
        route = str(environ.get(ROUTE_KEY, "<unmatched>"))
        method = environ.get("REQUEST_METHOD", "-")
        protocol = environ.get("SERVER_PROTOCOL", "-")
        blank = {"h": "-", "u": "-", "q": "", "f": "-", "a": "-", "U": route}
        atoms.update(blank, r=f"{method} {route} {protocol}")
        # Header and environ atoms ({name}i, {name}o, {name}e) may carry any of the above.
        for key in list(atoms):
            if key.startswith("{"):
                atoms[key] = "-"
        return atoms


def settings(host: str, port: int, workers: int) -> dict[str, object]:
    """gunicorn's settings for ``facepair serve``.

    Timeouts and limits bound what slow or hostile clients can hold: a worker silent for
    ``timeout`` seconds is restarted, an idle keep-alive connection closes after
    ``keepalive``, a request line, header count and header size beyond the limits is refused
    (400) before the app sees it. A gthread worker still gives each connection a thread while
    its headers arrive, so clients that trickle headers can tie up ``workers x threads``
    connections: in production put a buffering proxy in front (deploy/nginx.conf), as
    :func:`proxy_warning` says at start when none is configured.
    """
    return {
        "bind": f"{host}:{port}",
        "workers": workers,
        "threads": threads,
        "worker_class": worker_class,
        "timeout": timeout,
        "graceful_timeout": graceful_timeout,
        "keepalive": keepalive,
        "limit_request_line": limit_request_line,
        "limit_request_fields": limit_request_fields,
        "limit_request_field_size": limit_request_field_size,
        "accesslog": accesslog,
        "access_log_format": access_log_format,
        "logger_class": logger_class,
        **control_socket_off(),
    }


def control_socket_off() -> dict[str, object]:
    """The setting that turns gunicorn's control socket off, where this gunicorn has one
    (25.1 and later; the module docstring says why)."""
    if any(setting.name == "control_socket_disable" for setting in KNOWN_SETTINGS):
        return {"control_socket_disable": True}
    return {}


def proxy_warning(trust_proxy: int) -> str | None:
    """The line ``facepair serve`` prints when no front proxy is configured, or None."""
    if trust_proxy > 0:
        return None
    return (
        "warning: TRUST_PROXY is 0, so no front proxy is configured: clients that send their "
        "headers slowly can tie up the server's threads; put a buffering proxy in front "
        "(deploy/nginx.conf) and set TRUST_PROXY=1 (docs/operations.md)"
    )


# -- gunicorn's config-module names (gunicorn -c python:app.web.serving) -------------------
worker_class = "gthread"
threads = 4
timeout = 30
graceful_timeout = 30
keepalive = 5
limit_request_line = 4094
limit_request_fields = 100
limit_request_field_size = 8190
accesslog = "-"
access_log_format = ACCESS_LOG_FORMAT
logger_class = "app.web.serving.PrivateAccessLogger"
# an unknown name is ignored by a gunicorn older than 25.1, which has no control socket
control_socket_disable = True
bind = os.environ.get("FACEPAIR_BIND", "0.0.0.0:8000")
workers = int(os.environ.get("FACEPAIR_WORKERS", "3"))
