"""``POST /api/v1/prolific/webhook``: Prolific's webhook (``submission.status.change``,
``study.status.change``), checked and applied by ``app.web.prolific.outcomes``.

Off (404) until ``PROLIFIC_WEBHOOK_SECRET`` is set; HTTPS only (403 over plain HTTP).
``PROLIFIC_WEBHOOK_HTTPS_ONLY = false`` lifts that for a testing or debug application only (a
loopback test set-up): a production server never takes the webhook in clear text. A bad or
missing signature is 401; a redelivered event is acknowledged with 200 and not applied again.
The settings are read from the application's configuration, else the environment.
"""

from __future__ import annotations

import os

from flask import abort, current_app, jsonify, request

from app.web.api.blueprint import bp
from app.web.prolific.client import setting
from app.web.prolific.outcomes import MAX_AGE_SECONDS, receive

#: Prolific's events are a few hundred bytes.
MAX_BODY = 64 * 1024
OFF = ("0", "false", "no", "off")


def https_only() -> bool:
    """Whether plain HTTP is refused: always, but in a testing or debug application whose
    ``PROLIFIC_WEBHOOK_HTTPS_ONLY`` is false."""
    app = current_app
    value = app.config.get("PROLIFIC_WEBHOOK_HTTPS_ONLY")
    if value is None:
        value = os.environ.get("PROLIFIC_WEBHOOK_HTTPS_ONLY", "true")
    lifted = value is False or str(value).strip().lower() in OFF
    return not (lifted and (app.testing or app.debug))


@bp.post("/prolific/webhook")
def prolific_webhook():  # type: ignore[no-untyped-def]
    config = current_app.config
    secret = config.get("PROLIFIC_WEBHOOK_SECRET") or os.environ.get("PROLIFIC_WEBHOOK_SECRET")
    if not secret:
        abort(404)
    if https_only() and not request.is_secure:
        return jsonify({"error": "HTTPS only"}), 403
    if (request.content_length or 0) > MAX_BODY:
        return jsonify({"error": f"body: larger than {MAX_BODY // 1024} KB"}), 413
    body = request.stream.read(MAX_BODY + 1)
    if len(body) > MAX_BODY:
        return jsonify({"error": f"body: larger than {MAX_BODY // 1024} KB"}), 413
    max_age = setting(config, "PROLIFIC_WEBHOOK_MAX_AGE_SECONDS", MAX_AGE_SECONDS)
    status, answer = receive(request.headers, body, secret=str(secret), max_age=max_age)
    return jsonify(answer), status
