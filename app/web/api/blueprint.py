"""The API blueprint, ``bp``, under ``/api/v1``: the modules of the JSON endpoints add their
routes to it, and the package (``app.web.api``) imports them all."""

from flask import Blueprint

bp = Blueprint("api", __name__, url_prefix="/api/v1")
