"""A questionnaire for the web tests: the study-file questions, valid answers to the
demographics, and a questionnaire page answered as a participant's browser does. Nothing here is
part of the application."""

from __future__ import annotations

import re

#: A study file's questionnaire: the demographics before the trials, and two questions after
#: them, one optional, one a number of hours.
QUESTIONS = """demographics = true
[[questions]]
name = "comments"
text = "Any comments?"
page = "after"
required = false
[[questions]]
name = "hours"
text = "Hours of screen time a day"
page = "after"
type = "number"
min = 0
max = 24
"""
#: Valid answers to the demographics page (``before``).
BEFORE = {
    "age_band": "25-34",
    "gender": "female",
    "native_language": "Welsh",
    "vision_corrected": "no",
    "animation_experience": "none",
}


def answer_page(client, token, page, **values):
    """The response to posting ``values`` on the participant ``token``'s questionnaire page
    ``page`` (``before`` or ``after``), with the CSRF token of the form as served."""
    url = f"/p/{token}/questions/{page}"
    form = client.get(url).get_data(as_text=True)
    csrf = re.search(r'name="csrf_token" type="hidden" value="([^"]+)"', form).group(1)
    return client.post(url, data={"csrf_token": csrf, **values})
