"""The consent limits, counted where every web process sees them, in one atomic step.

``CONSENT_LIMIT_PER_ADDRESS`` (one client address in one study) and ``CONSENT_LIMIT_PER_STUDY``
(all addresses), in Flask-Limiter's syntax (``"10 per minute; 30 per hour"``), are fixed
windows as Flask-Limiter's are: a window opens at its first consent and takes at most the
limit's number. gunicorn's workers are processes, so a count kept in memory is one count per
worker (4 workers let 36 of 60 consents from one address through a limit of 10). The count
lives instead

* in Redis when ``REDIS_URL`` is set: the ``limits`` library's counter, whose INCRBY and EXPIRE
  run as one Lua script;
* else in the database (:class:`~app.web.models.RateCounter`): one ``INSERT ... ON CONFLICT DO
  UPDATE ... RETURNING`` raises the window's count, or opens a new window, in the consent's
  own transaction. PostgreSQL keeps the row locked until the commit, so the consents of one
  study (one address, with no per-study limit) are enrolled one at a time; SQLite has one
  writer anyway.

A consent is counted before its participant is enrolled and passes only if the count it raised
is within every limit. Reading the count first and raising it after the answer, as
Flask-Limiter's ``deduct_when`` does, let two processes both read 9 and both enrol (11 through
with Redis). A refused consent gives its count back (Redis) or is rolled back with it
(database), so refusals do not lengthen the wait; in the database a consent that fails later
takes its count back too. Only enrolments are counted: a resume, a refused form and the
consent page itself never reach the counter.

No address is stored: a key holds an HMAC of it under ``SECRET_KEY``, and a consent that
passes deletes the rows of windows that have ended.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import hmac
import logging
import math
import time
from dataclasses import dataclass
from typing import Any

import sqlalchemy as sa
from flask import current_app
from limits import parse_many
from limits.storage import Storage, storage_from_string
from sqlalchemy.dialects import postgresql, sqlite

from app.web.extensions import db
from app.web.models import RateCounter, utcnow

log = logging.getLogger(__name__)

_REDIS = "facepair.throttle.redis"


@dataclass(frozen=True)
class Window:
    """One limit applied to one study or one address in it: ``amount`` consents a window of
    ``seconds``, counted under ``key``."""

    key: str
    amount: int
    seconds: int


def address_key(address: str) -> str:
    """How a counter names a client address: an HMAC-SHA256 under ``SECRET_KEY`` (128 bits
    of it), so neither Redis nor the database holds the address."""
    secret = current_app.secret_key or b""
    if isinstance(secret, str):
        secret = secret.encode("utf-8")
    return hmac.new(secret, address.encode("utf-8"), hashlib.sha256).hexdigest()[:32]


def consent_windows(slug: str, address: str) -> list[Window]:
    """The windows a consent from ``address`` to the study ``slug`` counts in, by key (the
    order every process raises them in, so two never wait on each other's rows crosswise).
    The study's random slug, not its id, names it: a study made later under a reused id
    starts afresh."""
    config = current_app.config
    found = []
    for setting, whom in (
        ("CONSENT_LIMIT_PER_ADDRESS", f"address:{address_key(address)}"),
        ("CONSENT_LIMIT_PER_STUDY", "study"),
    ):
        text = str(config.get(setting) or "")
        for item in parse_many(text) if text.strip() else []:
            seconds = int(item.get_expiry())
            found.append(
                Window(f"consent:{slug}:{whom}:{item.amount}/{seconds}", item.amount, seconds)
            )
    return sorted(found, key=lambda window: window.key)


def _seconds_until(end: float) -> int:
    return max(1, math.ceil(end))


def _redis(app: Any) -> Storage | None:
    """The ``limits`` storage on ``REDIS_URL`` (one per application and URL), or None."""
    url = app.config.get("REDIS_URL")
    if not url:
        return None
    kept = app.extensions.get(_REDIS)
    if kept is None or kept[0] != url:
        kept = (url, storage_from_string(url))
        app.extensions[_REDIS] = kept
    return kept[1]  # type: ignore[no-any-return]


def count_consent(slug: str, address: str) -> int | None:
    """Count one consent from ``address`` to the study ``slug`` in each of its windows, before
    it is enrolled. Returns None if every count is within its limit; else the seconds until
    the window that refused it ends, and the caller rolls the transaction back (which takes
    back a count kept in the database)."""
    windows = consent_windows(slug, address)
    if not windows:
        return None
    store = _redis(current_app)
    if store is not None:
        try:
            return _count_in_redis(store, windows)
        except store.base_exceptions as exc:
            log.warning("Redis unreachable, consents counted in the database: %s", exc)
    return _count_in_database(windows, utcnow())


def _count_in_redis(store: Storage, windows: list[Window]) -> int | None:
    raised = []
    for window in windows:
        count = store.incr(window.key, window.seconds, amount=1)
        raised.append(window)
        if count > window.amount:
            wait = _seconds_until(store.get_expiry(window.key) - time.time())
            for taken in raised:
                store.incr(taken.key, taken.seconds, amount=-1)
            return wait
    return None


def _count_in_database(windows: list[Window], now: dt.datetime) -> int | None:
    session = db.session
    table = RateCounter
    insert = postgresql.insert if db.engine.dialect.name == "postgresql" else sqlite.insert
    for window in windows:
        fresh = insert(table).values(
            key=window.key, count=1, expires_at=now + dt.timedelta(seconds=window.seconds)
        )
        over = table.expires_at <= now
        raised = fresh.on_conflict_do_update(
            index_elements=[table.key],
            set_={
                "count": sa.case((over, 1), else_=table.count + 1),
                "expires_at": sa.case((over, fresh.excluded.expires_at), else_=table.expires_at),
            },
        ).returning(table.count, table.expires_at)
        count, ends = session.execute(raised).one()
        if count > window.amount:
            return _seconds_until((ends - now).total_seconds())
    # Ended windows of others go last, skipping any row another consent holds, so this step
    # never waits. Deleting them first, before raising its own rows, a consent could hold an
    # ended study window while waiting for its address's row, held by a consent from the same
    # address that waited for that study window: a deadlock (PostgreSQL).
    ended = sa.select(table.key).where(table.expires_at < now).with_for_update(skip_locked=True)
    session.execute(sa.delete(table).where(table.key.in_(ended)))
    return None
