"""Experimenter blueprint: login, studies, jobs, recruitment, monitor, export, reports."""

from flask import Blueprint

bp = Blueprint("experimenter", __name__, url_prefix="/experimenter")

# Each module adds its routes to ``bp`` (one module per idea).
from app.web.experimenter import (  # noqa: E402, F401
    create,
    lifecycle,
    participants,
    prolific,
    views,
)
