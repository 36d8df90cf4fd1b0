"""Questionnaire blueprint: the pages of questions before and after a participant's trials."""

from flask import Blueprint

bp = Blueprint("questionnaire", __name__)

from app.web.questionnaire import views  # noqa: E402, F401  (its routes register on bp)
