"""The leaderboard blueprint, ``bp``, under ``/leaderboard``: the board's pages (``views``) and
the submitters' (``submit``) add their routes to it, and the package (``app.web.leaderboard``)
imports them."""

from flask import Blueprint

bp = Blueprint("leaderboard", __name__, url_prefix="/leaderboard")
