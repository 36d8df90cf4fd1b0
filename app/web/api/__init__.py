"""API blueprint: JSON endpoints (votes, progress, job status)."""

# Their routes register on bp.
from app.web.api import prolific, views  # noqa: F401
from app.web.api.blueprint import bp

__all__ = ["bp"]
