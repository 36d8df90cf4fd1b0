"""Subscribing facepair's webhook to Prolific's events (``facepair prolific hooks``).

From Prolific's OpenAPI document and webhook guide: a workspace has one secret
(``POST /api/v1/hooks/secrets/`` replaces it); a subscription (``POST
/api/v1/hooks/subscriptions/`` with ``workspace_id``, ``event_type`` and an ``https`` target
URL) answers with an ``X-Hook-Secret`` header, sent back to confirm it (``POST
/api/v1/hooks/subscriptions/{id}/`` with ``{"secret": ...}``).
"""

from __future__ import annotations

import os
from urllib.parse import urlsplit

from app.errors import InputError
from app.web.prolific.client import ProlificClient, under_test
from app.web.prolific.outcomes import EVENT_TYPES


def workspace_id(client: ProlificClient, given: str | None) -> str:
    """``given``, else PROLIFIC_WORKSPACE_ID, else the token's only workspace."""
    if given or os.environ.get("PROLIFIC_WORKSPACE_ID"):
        return str(given or os.environ["PROLIFIC_WORKSPACE_ID"])
    found = client.get("/api/v1/workspaces/", call="list workspaces")
    ids = [
        str(w["id"])
        for w in (found or {}).get("results", [])
        if isinstance(w, dict) and w.get("id")
    ]
    if len(ids) != 1:
        raise InputError(
            f"the token sees {len(ids)} workspaces: name one with --workspace", field="workspace"
        )
    return ids[0]


def subscribe(
    client: ProlificClient, workspace: str, url: str, *, new_secret: bool
) -> tuple[str | None, list[str]]:
    """Subscribe ``url`` to :data:`EVENT_TYPES` (skipping subscriptions that exist); with
    ``new_secret``, replace the workspace's secret first and return it (shown once, kept
    nowhere). Returns (the new secret or None, one line per event type)."""
    parts = urlsplit(url)
    if parts.scheme != "https" and not (
        under_test() and parts.hostname in ("127.0.0.1", "localhost")
    ):
        raise InputError(f"Prolific calls https:// URLs only, got {url!r}", field="URL")
    secret = None
    if new_secret:
        made = client.request(
            "POST",
            "/api/v1/hooks/secrets/",
            call="create the webhook secret",
            json={"workspace_id": workspace},
        ).data
        secret = str((made or {}).get("value", ""))
    existing = client.get(
        "/api/v1/hooks/subscriptions/",
        call="list subscriptions",
        params={"workspace_id": workspace},
    )
    have = {
        (s.get("event_type"), s.get("target_url"))
        for s in (existing or {}).get("results", [])
        if isinstance(s, dict) and s.get("is_enabled", True)
    }
    lines = []
    for event_type in EVENT_TYPES:
        if (event_type, url) in have:
            lines.append(f"{event_type}: already subscribed")
            continue
        answer = client.request(
            "POST",
            "/api/v1/hooks/subscriptions/",
            call=f"subscribe to {event_type}",
            json={"workspace_id": workspace, "event_type": event_type, "target_url": url},
        )
        data = answer.data if isinstance(answer.data, dict) else {}
        results = data.get("results")
        if (
            not data.get("id")
            and isinstance(results, list)
            and results
            and isinstance(results[0], dict)
        ):
            data = results[0]
        subscription = str(data.get("id", ""))
        confirm = answer.headers.get("X-Hook-Secret", "")
        if not subscription or not confirm:
            raise InputError(
                f"Prolific gave no subscription id or X-Hook-Secret for {event_type}", field="URL"
            )
        client.request(
            "POST",
            f"/api/v1/hooks/subscriptions/{subscription}/",
            call=f"confirm the {event_type} subscription",
            json={"secret": confirm},
        )
        lines.append(f"{event_type}: subscribed ({subscription})")
    return secret, lines
