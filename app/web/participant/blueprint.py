"""The participant blueprint, ``bp``: the modules of the participant's pages add their routes to
it, and the package (``app.web.participant``) imports them all."""

from flask import Blueprint

bp = Blueprint("participant", __name__)
