"""API blueprint: JSON endpoints (votes, progress, job status)."""

from flask import Blueprint

bp = Blueprint("api", __name__, url_prefix="/api/v1")

from app.web.api import views  # noqa: E402, F401  (its routes register on bp)
