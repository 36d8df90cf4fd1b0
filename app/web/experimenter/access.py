"""Which study an experimenter's request may touch: the one rule every experimenter page uses."""

from __future__ import annotations

from flask import abort

from app.web.extensions import db
from app.web.infra.accounts import ACCESS_LEVELS, current_user, study_access
from app.web.models import Study


def own_study(study_id: int, need: str = "read") -> Study:
    """The study if the logged-in experimenter has at least ``need`` access to it; 404 if they
    have none (no leak that it exists), 403 if they may only look."""
    study = db.session.get(Study, study_id)
    user = current_user()
    access = None if study is None or user is None else study_access(study, user.id)
    if access is None:
        abort(404)
    if ACCESS_LEVELS.index(access) < ACCESS_LEVELS.index(need):
        abort(403)
    return study  # type: ignore[return-value]
