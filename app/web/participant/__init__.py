"""Participant blueprint: consent, instructions with a practice pair, the audio check, trials,
completion."""

# Their routes register on bp.
from app.web.participant import audio, items, renditions, views  # noqa: F401
from app.web.participant.blueprint import bp

__all__ = ["bp"]
