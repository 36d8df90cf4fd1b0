"""Rating a rating study's trials through ``POST /api/v1/ratings``, as a participant's page
does, for the tests of ratings and of what reads them (``tests/web/study/``). Nothing here is
part of the application."""

from __future__ import annotations

import secrets
from typing import Any

from app.web.extensions import db
from app.web.models import Study

#: A parallel study's setting: its hidden reference is the condition ``none``.
PARALLEL = 'reference = "none"\n'


def rate_trial(client, token: str, trial_id: int, score: Any = 4, **extra: Any):
    """The response to ``POST /api/v1/ratings``: ``token``'s rating ``score`` of ``trial_id``,
    played once to its end, under a fresh idempotency key (or ``key``); ``extra`` adds to or
    replaces the payload's fields."""
    payload = {
        "token": token,
        "trial_id": trial_id,
        "score": score,
        "plays": 1,
        "watched_to_end": True,
        "response_ms": 900,
        "presented_at": "2026-01-01T10:00:00Z",
        "idempotency_key": extra.pop("key", None) or secrets.token_hex(8),
        "media": {"watched_ms": 500, "played_to_end": True},
        **extra,
    }
    return client.post("/api/v1/ratings", json=payload)


def rate_all(app, client, participant, slug: str, score: int, *, check: int = 1) -> str:
    """A participant from consent to done, rating every clip ``score`` (checks ``check``)."""
    from app.web.models import Trial

    token = participant.join(slug)
    while (trial := participant.current_trial()) is not None:
        with app.app_context():
            kind = db.session.get(Trial, trial).kind
        response = rate_trial(client, token, trial, check if kind == "catch" else score)
        assert response.status_code == 201, response.get_json()
    return token


def parallel_participants(app, client, participant, web, reference_scores) -> int:
    """A parallel study with one finished participant per score given to the hidden
    reference (the other version rated 60); its id."""
    from app.web.models import Trial
    from app.web.study.ratings import shown_items

    study_id = web.study(design="parallel", extra=PARALLEL)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    for reference_score in reference_scores:
        token = participant.join(slug)
        trial = participant.current_trial()
        with app.app_context():
            row = db.session.get(Trial, trial)
            shown = [c.name for c in shown_items(row.participant, row)]
        scores = [reference_score if c == "none" else 60 for c in shown]
        payload = {"token": token, "trial_id": trial, "scores": scores, "plays": 2}
        payload["idempotency_key"] = f"screen-{trial:08d}"
        assert client.post("/api/v1/ratings", json=payload).status_code == 201
        client.delete_cookie(f"fp-{study_id}")
    return study_id
