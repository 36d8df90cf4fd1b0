"""Studies for the web tests: study-file text that several test modules build on, and a study's
public slug read back. Nothing here is part of the application."""

from __future__ import annotations

from app.web.extensions import db
from app.web.models import Study

#: A study file of two named conditions (one with its model's settings), its render settings
#: and one clip, ``s1.wav``: a format string (its braces doubled), so ``.format()`` gives the
#: TOML.
NAMED_CONDITIONS = """
title = "Named conditions"
question = "Which face moves more naturally?"
design = "unordered_counterbalanced"
seed = 5
eyes = "still"
practice = false

[render]
size = 128
mosaic_block = 16

[[conditions]]
name = "calm"
model = "random"
settings = {{ octaves = 1, persistence = 0.5 }}

[[conditions]]
name = "lively"
model = "random"

[[clips]]
name = "s1"
audio = "s1.wav"
"""

#: Six random conditions more, for a study file's ``extra``: with the file's two, eight.
EIGHT_CONDITIONS = "".join(f'\n[[conditions]]\nname = "r{k}"\nmodel = "random"\n' for k in range(6))


def study_slug(app, study_id: int) -> str:
    """The slug of the study ``study_id``: its public link is ``/s/<slug>``."""
    with app.app_context():
        return db.session.get(Study, study_id).slug
