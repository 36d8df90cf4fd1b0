"""Experimenter blueprint: login, studies, jobs, recruitment, monitor, export, reports."""

from flask import Blueprint

bp = Blueprint("experimenter", __name__, url_prefix="/experimenter")

from app.web.experimenter import views  # noqa: E402, F401  (its routes register on bp)
