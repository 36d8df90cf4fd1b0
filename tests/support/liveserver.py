"""A threaded werkzeug server for browser tests, one that always closes what it served.

werkzeug's development server calls the response's ``close()`` at the end of a ``finally`` that
first drains the request socket. When the client resets the connection during that drain (a
browser cancelling a video's range request does), the read raises and ``close()`` is skipped:
the open media file is then finalised by the garbage collector with a ``ResourceWarning``, which
the tests treat as an error. :func:`serve` wraps the application so each request's response is
closed once, after the handler has finished, whatever the client did. gunicorn, which serves
facepair in production, is not concerned. Nothing here is part of the application.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

from werkzeug.serving import WSGIRequestHandler, make_server

_RESPONSE = "facepair.tests.response"


class _ClosesOnce:
    """A WSGI response iterable whose ``close()`` runs the wrapped one's at most once."""

    def __init__(self, iterable):
        self._iterable = iterable
        self._closed = False

    def __iter__(self):
        return iter(self._iterable)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        close = getattr(self._iterable, "close", None)
        if close is not None:
            close()


class _ClosingHandler(WSGIRequestHandler):
    """Closes the request's response after werkzeug's handler, if werkzeug did not."""

    def run_wsgi(self) -> None:
        try:
            super().run_wsgi()
        finally:
            response = getattr(self, "environ", {}).pop(_RESPONSE, None)
            if response is not None:
                response.close()


def _remembering(app):
    def wsgi(environ, start_response):
        response = _ClosesOnce(app(environ, start_response))
        environ[_RESPONSE] = response
        return response

    return wsgi


@contextmanager
def serve(app) -> Iterator[str]:
    """Serve the WSGI ``app`` on a free port of 127.0.0.1 in a thread; yields its base URL."""
    server = make_server(
        "127.0.0.1", 0, _remembering(app), threaded=True, request_handler=_ClosingHandler
    )
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.port}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=10)
