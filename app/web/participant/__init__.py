"""Participant blueprint: consent, instructions with a practice pair, trials, completion."""

from flask import Blueprint

bp = Blueprint("participant", __name__)

from app.web.participant import items, views  # noqa: E402, F401  (their routes register on bp)
