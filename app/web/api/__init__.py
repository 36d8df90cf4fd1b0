"""API blueprint: JSON endpoints (votes, progress, job status)."""

from flask import Blueprint

bp = Blueprint("api", __name__, url_prefix="/api/v1")

from app.web.api import prolific, views  # noqa: E402, F401  (their routes register on bp)
