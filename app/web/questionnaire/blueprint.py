"""The questionnaire blueprint, ``bp``: its pages (``views``) add their routes to it, and the
package (``app.web.questionnaire``) imports them."""

from flask import Blueprint

bp = Blueprint("questionnaire", __name__)
