"""The experimenter blueprint, ``bp``, under ``/experimenter``: each module of the experimenter's
pages adds its routes to it, and the package (``app.web.experimenter``) imports them all."""

from flask import Blueprint

bp = Blueprint("experimenter", __name__, url_prefix="/experimenter")
