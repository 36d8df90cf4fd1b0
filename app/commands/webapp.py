"""The web application as the commands run it: built from the environment (:func:`web_app`,
:func:`offline_app`), entered with its database connections closed on the way out
(:func:`app_context`), and served (:func:`serve_app`).

The web layer is imported inside the functions, so that ``facepair`` starts without loading
Flask; a command's application starts as every process's that answers no web request
(:mod:`app.web.standalone`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click


def web_app(**config: Any):  # type: ignore[no-untyped-def]
    """The application from the environment and ``config`` (a deployment key required)."""
    from app.web import create_app

    return create_app(config or None)


def offline_app():  # type: ignore[no-untyped-def]
    """The app for commands that answer no web request: no session is ever signed, so no
    deployment key is needed."""
    from app.web.standalone import offline_app as standalone_app

    return standalone_app()


@contextmanager
def app_context(app) -> Iterator[None]:  # type: ignore[no-untyped-def]
    """An application context whose database connections are closed on the way out."""
    from app.web.standalone import app_context as standalone_context

    with standalone_context(app):
        yield


def serve_app(  # type: ignore[no-untyped-def]
    app, host: str, port: int, workers: int, dev: bool, log: Path | None = None
) -> None:
    """Serve ``app`` with gunicorn (``dev``: Flask's server). With ``log`` (the demo, on this
    machine alone) gunicorn's messages and access log go to that file and the warning about a
    missing front proxy, a production matter, is not shown."""
    if dev:
        app.run(host=host, port=port, threaded=True, use_reloader=False)
        return
    from gunicorn.app.base import BaseApplication

    from app.web.serving import proxy_warning, settings

    warning = proxy_warning(int(app.config.get("TRUST_PROXY") or 0))
    if warning and log is None:
        click.echo(warning, err=True)
    chosen = settings(host, port, workers)
    if log is not None:
        chosen |= {"errorlog": str(log), "accesslog": str(log)}

    class Server(BaseApplication):  # type: ignore[misc]
        def load_config(self) -> None:
            for key, value in chosen.items():
                self.cfg.set(key, value)

        def load(self):  # type: ignore[no-untyped-def]
            return app

    Server().run()
