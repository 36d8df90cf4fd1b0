"""Experimenter login: hashed passwords (werkzeug), logins kept on the server
(:class:`~app.web.models.LoginSession`, so logout, "log out everywhere" and a password change
end them, with idle and absolute timeouts), and what each experimenter may do with a study
(owner, or a collaborator it is shared with).

The signed session cookie holds a random key of the login, never anything that grants access by
itself: a cookie copied before logout, or signed long ago, names a login that has ended. The
rules follow OWASP ASVS 4.0 level 1, V2 (passwords) and V3 (sessions); docs/reference/web.md,
"Security", lists each item and how it is met.
"""

from __future__ import annotations

import datetime as dt
import functools
import hashlib
import secrets
from collections.abc import Callable
from typing import Any

import sqlalchemy as sa
from email_validator import EmailNotValidError, validate_email
from flask import current_app, g, redirect, request, session, url_for
from werkzeug.security import check_password_hash, generate_password_hash

from app.errors import InputError
from app.web.extensions import db
from app.web.infra.limits import fits
from app.web.infra.passwords import is_common, user_words
from app.web.models import (
    LoginSession,
    Study,
    StudyShare,
    User,
    password_hash_method,
    utcnow,
)

#: A login's last request is written at most this often (the idle timeout's resolution).
SEEN_EVERY = dt.timedelta(minutes=1)


def _key_hash(key: str) -> str:
    return hashlib.sha256(key.encode("utf-8")).hexdigest()


def start_login(user: User) -> None:
    """Begin a login for ``user``: a new server-side record and a fresh session cookie."""
    key = secrets.token_urlsafe(32)
    db.session.add(LoginSession(user_id=user.id, key_hash=_key_hash(key)))
    session.clear()
    session["login"] = key


def _login_record() -> LoginSession | None:
    key = session.get("login")
    if not isinstance(key, str) or not key:
        return None
    return db.session.scalar(sa.select(LoginSession).where(LoginSession.key_hash == _key_hash(key)))


def login_is_live(record: LoginSession, now: dt.datetime, idle: float, absolute: float) -> bool:
    """Whether a login may still be used: not ended, younger than ``absolute`` hours and seen
    within the last ``idle`` minutes (ASVS 3.3.1, 3.3.2)."""
    return (
        record.ended_at is None
        and now - record.created_at < dt.timedelta(hours=absolute)
        and now - record.seen_at < dt.timedelta(minutes=idle)
    )


def current_user() -> User | None:
    """The experimenter of this request's live login, or None (an ended, idle or expired
    login clears the cookie's session)."""
    if "user" not in g:
        g.user = None
        record = _login_record()
        if record is not None:
            now = utcnow()
            config = current_app.config
            live = login_is_live(
                record, now, config["SESSION_IDLE_MINUTES"], config["SESSION_ABSOLUTE_HOURS"]
            )
            if live:
                if now - record.seen_at >= SEEN_EVERY:
                    record.seen_at = now
                    db.session.commit()
                g.user = db.session.get(User, record.user_id)
                g.login = record
            else:
                session.clear()
        elif session.get("user_id") is not None:
            session.clear()  # a cookie from before logins were kept: log in again
    return g.user


def end_login() -> None:
    """Logout: end this login on the server (its cookie no longer opens anything)."""
    record = _login_record()
    if record is not None and record.ended_at is None:
        record.ended_at = utcnow()
        db.session.commit()
    session.clear()


def end_logins(user: User, *, keep: LoginSession | None = None) -> int:
    """End every live login of ``user`` but ``keep``: "log out everywhere", a password change.
    Returns how many were ended."""
    query = sa.update(LoginSession).where(
        LoginSession.user_id == user.id, LoginSession.ended_at.is_(None)
    )
    if keep is not None:
        query = query.where(LoginSession.id != keep.id)
    ended = db.session.execute(query.values(ended_at=utcnow())).rowcount
    db.session.commit()
    return int(ended or 0)


def login_required(view: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(view)
    def wrapped(*args: Any, **kwargs: Any) -> Any:
        if current_user() is None:
            return redirect(url_for("experimenter.login", next=request.path))
        return view(*args, **kwargs)

    return wrapped


#: A hash checked when no account has the e-mail, so an unknown address takes as long as a
#: wrong password (no account enumeration by timing, ASVS 2.2.1 / 3.x guidance).
_DUMMY_HASH: dict[str, str] = {}


def _dummy_hash() -> str:
    method = password_hash_method()
    if method not in _DUMMY_HASH:
        _DUMMY_HASH[method] = generate_password_hash(secrets.token_urlsafe(16), method)
    return _DUMMY_HASH[method]


def authenticate(email: str, password: str) -> User | None:
    """The account with this e-mail and password, or None; the same work either way."""
    email = email.strip().lower()
    user = (
        db.session.scalar(sa.select(User).where(User.email == email))
        if fits(User.email, email)
        else None
    )
    if user is None:
        check_password_hash(_dummy_hash(), password)
        return None
    return user if user.check_password(password) else None


def create_user(email: str, password: str) -> User:
    """A new experimenter (not committed); the e-mail is validated and stored normalised
    (lower-case), the password checked by :func:`password_problem`. Raises
    :class:`~app.errors.InputError` naming the field."""
    address = normalise_email(email)
    if db.session.scalar(sa.select(User.id).where(User.email == address)) is not None:
        raise InputError(f"an experimenter {address} already exists", field="email")
    problem = password_problem(password, address)
    if problem:
        raise InputError(problem, field="password")
    user = User(email=address)
    user.set_password(password)
    db.session.add(user)
    return user


def change_password(user: User, password: str) -> int:
    """Set a new password and end every other login of ``user`` (ASVS 3.3.3); returns how
    many logins were ended. The current login, if any, stays."""
    problem = password_problem(password, user.email)
    if problem:
        raise InputError(problem, field="password")
    user.set_password(password)
    return end_logins(user, keep=g.get("login"))


def normalise_email(email: str) -> str:
    """The address as stored: syntax checked by ``email-validator`` (no DNS lookup), then
    lower-case. Raises :class:`~app.errors.InputError` (field ``email``)."""
    try:
        found = validate_email(email.strip(), check_deliverability=False)
    except EmailNotValidError as exc:
        raise InputError(f"not an e-mail address: {exc}", field="email") from None
    address = found.normalized.lower()
    if not fits(User.email, address):
        raise InputError("at most 200 characters", field="email")
    return address


#: ASVS 2.1.1: at least 12 characters; 2.1.2: up to 128 allowed; 2.1.7: not a common password.
MIN_PASSWORD, MAX_PASSWORD = 12, 128


def password_problem(password: str, email: str = "") -> str | None:
    """Why ``password`` is refused, or None: shorter than :data:`MIN_PASSWORD` or longer than
    :data:`MAX_PASSWORD` characters, guessable by :func:`app.web.infra.passwords.is_common`
    (the account's e-mail and its parts counting as known words), or the e-mail itself."""
    if len(password) < MIN_PASSWORD:
        return f"at least {MIN_PASSWORD} characters (a passphrase of a few words is best)"
    if len(password) > MAX_PASSWORD:
        return f"at most {MAX_PASSWORD} characters"
    if is_common(password, user_words(email)):
        return "a common password that attackers try first; choose another"
    if email and password.strip().lower() in {email.lower(), email.split("@")[0].lower()}:
        return "must not be the e-mail address"
    return None


#: What each level of access allows, weakest first: a collaborator with "read" sees the
#: study, its monitor, exports and report; "full" also runs it; only the owner shares,
#: deletes or reads the raw Prolific IDs.
ACCESS_LEVELS = ("read", "full", "owner")


def study_access(study: Study, user_id: int) -> str | None:
    """The access ``user_id`` has to ``study`` (one of :data:`ACCESS_LEVELS`), or None."""
    if study.owner_id == user_id:
        return "owner"
    return db.session.scalar(
        sa.select(StudyShare.access).where(
            StudyShare.study_id == study.id, StudyShare.user_id == user_id
        )
    )
