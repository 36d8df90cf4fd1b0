"""Fixtures of the experimenter's pages: the fake Prolific, the environment pointing facepair's
client at it and a recruiting study (``tests/web/prolific/conftest.py``), for the study's
Prolific page (``test_prolific.py``)."""

from tests.web.prolific.conftest import fake, prolific_env, recruiting_study  # noqa: F401 (fixtures)
