"""Consents counted where every worker sees them: gunicorn's workers in one count, on SQLite and
PostgreSQL, with Redis and without."""

import secrets

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant
from tests.support.served import consent_crowd, facepair_serve, serve_env
from tests.support.studies import study_slug


def _participants(app, study_id: int) -> int:
    with app.app_context():
        return db.session.scalar(
            sa.select(sa.func.count(Participant.id)).where(Participant.study_id == study_id)
        )


@pytest.mark.parametrize("redis", [False, True], ids=["database", "redis"])
def test_four_workers_let_through_no_more_consents_than_the_address_limit(
    app, web, tmp_path, request, redis
):
    """40 browsers behind one address post the consent form at once to 4 gunicorn workers;
    the limit is 10 a minute per address and study. Before, each worker counted its own (36
    of 60 passed without Redis), and with Redis a check before the count let 11 through."""
    study_id = web.study()
    slug = study_slug(app, study_id)
    settings = {
        "DATABASE_URL": app.config["SQLALCHEMY_DATABASE_URI"],
        "SECRET_KEY": secrets.token_hex(32),
        "MEDIA_ROOT": app.config["MEDIA_ROOT"],
    }
    if redis:
        settings["REDIS_URL"] = request.getfixturevalue("redis_url")
    env = serve_env(tmp_path, **settings)
    with facepair_serve(env, workers=4, log=tmp_path / "serve.log") as base:
        codes = consent_crowd(base, slug, 40)
    assert codes.count(302) == _participants(app, study_id)
    assert codes.count(302) == 10, codes  # no more than the limit, and no fewer
    assert set(codes) <= {302, 429}, codes


def _consent(app, slug: str, address: str):
    """One consent counted as the view counts it: committed if it passes, else rolled back."""
    from app.web.infra import throttle

    with app.app_context():
        wait = throttle.count_consent(slug, address)
        if wait is None:
            db.session.commit()
        else:
            db.session.rollback()
        return wait


def _counters(app) -> dict[str, tuple[int, object]]:
    from app.web.models import RateCounter

    with app.app_context():
        return {
            row.key: (row.count, row.expires_at)
            for row in db.session.scalars(sa.select(RateCounter))
        }


def test_the_database_count_refuses_beyond_the_limit_and_keeps_no_address(app):
    app.config.update(CONSENT_LIMIT_PER_ADDRESS="2 per minute", CONSENT_LIMIT_PER_STUDY="")
    assert [_consent(app, "s1", "203.0.113.7") for _ in range(2)] == [None, None]
    wait = _consent(app, "s1", "203.0.113.7")
    assert wait is not None and 1 <= wait <= 60
    assert _consent(app, "s1", "198.51.100.1") is None  # another address
    assert _consent(app, "s2", "203.0.113.7") is None  # another study
    rows = _counters(app)
    assert sorted(count for count, _ in rows.values()) == [1, 1, 2]  # the refusal gave it back
    assert not any("203.0.113" in key or "198.51" in key for key in rows)


def test_an_ended_window_starts_afresh_and_ended_rows_are_removed(app):
    import datetime as dt

    from app.web.models import RateCounter

    app.config.update(CONSENT_LIMIT_PER_ADDRESS="1 per minute", CONSENT_LIMIT_PER_STUDY="")
    assert _consent(app, "s1", "203.0.113.7") is None
    assert _consent(app, "s2", "203.0.113.7") is None
    assert _consent(app, "s1", "203.0.113.7") is not None
    with app.app_context():  # a minute later
        db.session.execute(
            sa.update(RateCounter).values(expires_at=RateCounter.expires_at - dt.timedelta(hours=1))
        )
        db.session.commit()
    assert _consent(app, "s1", "203.0.113.7") is None
    rows = _counters(app)
    assert len(rows) == 1 and next(iter(rows.values()))[0] == 1  # s2's ended row is gone


def test_the_redis_count_refuses_beyond_the_limit_and_gives_refusals_back(app, redis_url):
    app.config.update(
        CONSENT_LIMIT_PER_ADDRESS="2 per minute", CONSENT_LIMIT_PER_STUDY="", REDIS_URL=redis_url
    )
    slug = f"redis-{secrets.token_hex(4)}"
    from app.web.infra import throttle

    waits = [_consent(app, slug, "203.0.113.7") for _ in range(4)]
    assert waits[:2] == [None, None] and all(w is not None and 1 <= w <= 60 for w in waits[2:])
    with app.app_context():
        (window,) = throttle.consent_windows(slug, "203.0.113.7")
        assert throttle._redis(app).get(window.key) == 2  # the refusals gave theirs back
    assert _counters(app) == {}  # nothing in the database
