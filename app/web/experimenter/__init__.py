"""Experimenter blueprint: login, studies, jobs, recruitment, monitor, export, reports."""

# Each module adds its routes to ``bp`` (one module per idea).
from app.web.experimenter import (  # noqa: F401
    create,
    lifecycle,
    participants,
    prolific,
    views,
)
from app.web.experimenter.blueprint import bp

__all__ = ["bp"]
