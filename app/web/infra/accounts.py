"""Experimenter login: hashed passwords (werkzeug), the user id in the signed session; what
each experimenter may do with a study (owner, or a collaborator it is shared with)."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import sqlalchemy as sa
from flask import g, redirect, request, session, url_for

from app.web.extensions import db
from app.web.infra.limits import fits
from app.web.models import Study, StudyShare, User


def current_user() -> User | None:
    if "user" not in g:
        user_id = session.get("user_id")
        g.user = db.session.get(User, user_id) if user_id is not None else None
    return g.user


def login_required(view: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(view)
    def wrapped(*args: Any, **kwargs: Any) -> Any:
        if current_user() is None:
            return redirect(url_for("experimenter.login", next=request.path))
        return view(*args, **kwargs)

    return wrapped


def authenticate(email: str, password: str) -> User | None:
    email = email.strip().lower()
    if not fits(User.email, email):
        return None  # no account can have it
    user = db.session.scalar(sa.select(User).where(User.email == email))
    if user is None or not user.check_password(password):
        return None
    return user


def create_user(email: str, password: str) -> User:
    """A new experimenter (not committed); e-mail addresses are stored lower-case."""
    if len(password) < 8:
        raise ValueError("password: at least 8 characters")
    user = User(email=email.strip().lower())
    user.set_password(password)
    db.session.add(user)
    return user


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
