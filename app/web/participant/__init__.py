"""Participant blueprint: consent, instructions with a practice pair, the audio check, trials,
completion."""

from flask import Blueprint

bp = Blueprint("participant", __name__)

# Their routes register on bp.
from app.web.participant import audio, items, renditions, views  # noqa: E402, F401
