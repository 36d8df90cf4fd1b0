"""Leaderboard blueprint: the public board, its files, and the submitters' pages (submit, the
private preview). What each page decides is a service of ``app.web.board``."""

from app.web.leaderboard import submit, views  # noqa: F401  (their routes register on bp)
from app.web.leaderboard.blueprint import bp

__all__ = ["bp"]
