"""The bare baseline of ``bench_load.py --baseline``: the least a vote endpoint can do.

One Flask app, one ``POST /votes`` that reads the JSON body and inserts one row through psycopg
(one connection per server thread, kept open: a pool of workers x threads), served by gunicorn
with the settings of ``facepair serve``. facepair's saturated vote throughput is reported as a
fraction of this one's, on the same machine, database and load generator.

    python benchmarks/bare_baseline.py --dsn postgresql://postgres@127.0.0.1/db --port 5078
"""

from __future__ import annotations

import argparse
import sys
import threading
from pathlib import Path

import psycopg
from flask import Flask, jsonify, request

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

TABLE = """CREATE TABLE IF NOT EXISTS bare_vote (
    id serial PRIMARY KEY, token varchar(64) NOT NULL, trial_id integer NOT NULL,
    choice varchar(10) NOT NULL, idempotency_key varchar(64) NOT NULL UNIQUE,
    voted_at timestamp NOT NULL DEFAULT now())"""


def bare_app(dsn: str) -> Flask:
    app = Flask(__name__)
    local = threading.local()

    @app.post("/votes")
    def vote():  # type: ignore[no-untyped-def]
        payload = request.get_json()
        if not hasattr(local, "conn"):
            local.conn = psycopg.connect(dsn, autocommit=True)
        row = local.conn.execute(
            "INSERT INTO bare_vote (token, trial_id, choice, idempotency_key) "
            "VALUES (%s, %s, %s, %s) RETURNING id",
            (payload["token"], payload["trial_id"], payload["choice"], payload["idempotency_key"]),
        ).fetchone()
        return jsonify({"id": row[0], "choice": payload["choice"]}), 201

    return app


def main() -> None:
    from gunicorn.app.base import BaseApplication

    from app.web.serving import settings as gunicorn_settings

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dsn", required=True)
    parser.add_argument("--port", type=int, default=5078)
    parser.add_argument("--workers", type=int, default=4)
    args = parser.parse_args()
    with psycopg.connect(args.dsn, autocommit=True) as conn:
        conn.execute(TABLE)
    app = bare_app(args.dsn)

    class Server(BaseApplication):  # type: ignore[misc]
        def load_config(self) -> None:
            for key, value in gunicorn_settings("127.0.0.1", args.port, args.workers).items():
                self.cfg.set(key, value)

        def load(self):  # type: ignore[no-untyped-def]
            return app

    Server().run()


if __name__ == "__main__":
    main()
