"""The web application: ``create_app`` and what it is made of.

- ``extensions`` (unbound, initialised here), ``models`` (the typed SQLAlchemy models) and
  ``hooks`` (database pragmas, the idle-connection ping, the error pages);
- the blueprints ``participant``, ``experimenter``, ``questionnaire``, ``api`` and
  ``leaderboard`` (each ``bp`` in its ``blueprint`` module): they call the services and never
  each other;
- ``study``: the services (studies, enrolment, votes, ratings, plays, participants, exports,
  privacy, questionnaires, monitor, recruitment, media logs, ...), with no request objects;
- ``infra``: accounts, passwords, limits, security, storage and media delivery;
- ``jobs``: background jobs (their bodies, the queue's names, the sweeper); the entry points a
  runner starts by dotted name (``jobs.tasks``, ``jobs.clips``) are never imported here, and
  the renderer is imported only inside functions (a render, a WebM rendition, a new study's
  face);
- ``prolific`` (recruitment through Prolific's API) and ``board`` (the leaderboard's seasons);
- ``standalone``: the application of a process that answers no request;
- ``templates``, ``static``, ``migrations`` and ``translations``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from flask import Flask

from app.web.extensions import init_extensions
from app.web.hooks import init_web
from app.web.infra.i18n import init_i18n
from app.web.infra.media import DEFAULTS as MEDIA_DEFAULTS
from app.web.infra.media import init_media
from app.web.infra.security import init_security


def embedded_database_uri(instance_path: str) -> str:
    """The default database: SQLite in the instance folder (the only one ``demo`` accepts)."""
    return "sqlite:///" + os.path.join(instance_path, "facepair.sqlite")


def create_app(config: Mapping[str, Any] | None = None) -> Flask:
    """Application factory: defaults -> instance ``config.py`` -> environment -> ``config``.

    The environment variables read are ``DATABASE_URL``, ``SECRET_KEY``, ``REDIS_URL``,
    ``MEDIA_ROOT`` and ``TRUST_PROXY``. With no configuration the database is SQLite in the
    instance folder (``FACEPAIR_INSTANCE`` moves that folder). Outside tests a real
    ``SECRET_KEY`` is required: without one the factory raises :class:`app.errors.InputError`
    naming the setting.
    """

    app = Flask(
        __name__, instance_relative_config=True, instance_path=os.environ.get("FACEPAIR_INSTANCE")
    )
    os.makedirs(app.instance_path, exist_ok=True)
    app.config.from_mapping(
        # None: refused outside tests (app.security.check_secret_key).
        SECRET_KEY=None,
        REQUIRE_SECRET_KEY=True,
        # Reverse proxies in front of the app whose X-Forwarded-* headers are trusted.
        TRUST_PROXY=0,
        # Failed logins allowed per account and per client address (Flask-Limiter syntax).
        LOGIN_LIMIT_PER_ACCOUNT="5 per minute; 30 per hour",
        LOGIN_LIMIT_PER_ADDRESS="20 per minute; 200 per hour",
        # The largest study a deployment takes (one-line refusal at creation).
        MAX_CONDITIONS=20,
        MAX_CLIPS=100,
        MAX_TRIALS_PER_PARTICIPANT=1000,
        # An experimenter's login ends after this long without a request, and this long after
        # it began whatever happens (app.web.infra.accounts).
        SESSION_IDLE_MINUTES=60,
        SESSION_ABSOLUTE_HOURS=12,
        # How experimenters' passwords are hashed (werkzeug's method syntax); a weaker one than
        # app.web.infra.security.MIN_PASSWORD_HASH is refused outside tests.
        PASSWORD_HASH_METHOD="scrypt:32768:8:1",
        # Consents (new participants) allowed per client address in one study, and per study
        # from all addresses (Flask-Limiter syntax; "" for no limit). A lab whose participants
        # share one address raises the first (docs/reference/configuration.md).
        CONSENT_LIMIT_PER_ADDRESS="10 per minute; 30 per hour",
        CONSENT_LIMIT_PER_STUDY="120 per minute",
        SQLALCHEMY_DATABASE_URI=embedded_database_uri(app.instance_path),
        # No pre-ping on every checkout: a connection idle in the pool is pinged (app.web).
        SQLALCHEMY_ENGINE_OPTIONS={},
        MEDIA_ROOT=os.path.join(app.instance_path, "media"),
        REDIS_URL=None,
        # "process": a spawned local process; "inline": run at once (tests); RQ if REDIS_URL
        # is set (app.jobs).
        JOB_RUNNER="process",
        # A running job silent this long (its process died) is swept as failed.
        JOB_STALE_AFTER_SECONDS=900,
        # Minutes without activity after which an unfinished participant counts as dropped.
        DROPPED_AFTER_MINUTES=30,
        # Minutes after consent without a first trial after which a participant's slot is
        # given back (a burst of consents that never start must not hold the lists).
        UNSTARTED_AFTER_MINUTES=15,
        MAX_CONTENT_LENGTH=200 * 1024 * 1024,
        # Leaderboard submissions taken per client address (Flask-Limiter syntax; "" for none).
        LEADERBOARD_UPLOAD_LIMIT="20 per hour",
        # Seconds a client is asked to wait (Retry-After) while the database is unreachable.
        RETRY_AFTER_SECONDS=5,
    )

    # Who sends clips, audio and reports: Flask, the front proxy or a bucket (infra.media).
    app.config.from_mapping(MEDIA_DEFAULTS)
    app.config.from_pyfile("config.py", silent=True)
    if os.environ.get("DATABASE_URL"):
        app.config["SQLALCHEMY_DATABASE_URI"] = os.environ["DATABASE_URL"]
    for key in ("SECRET_KEY", "REDIS_URL", "MEDIA_ROOT", "TRUST_PROXY", *MEDIA_DEFAULTS):
        if os.environ.get(key):
            app.config[key] = os.environ[key]
    if config:
        app.config.update(config)
    init_security(app)
    init_media(app)
    init_extensions(app)
    init_i18n(app)
    init_web(app)
    return app
