"""Questionnaire blueprint: the pages of questions before and after a participant's trials."""

from app.web.questionnaire import views  # noqa: F401  (its routes register on bp)
from app.web.questionnaire.blueprint import bp

__all__ = ["bp"]
