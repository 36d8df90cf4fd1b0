"""Leaderboard blueprint: the public board, its files, and the submitters' pages (submit, the
private preview). What each page decides is a service of ``app.web.board``."""

from flask import Blueprint

bp = Blueprint("leaderboard", __name__, url_prefix="/leaderboard")

from app.web.leaderboard import submit, views  # noqa: E402, F401  (their routes register on bp)
