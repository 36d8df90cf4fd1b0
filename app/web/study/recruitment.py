"""Recruiting on Prolific: the study URL to paste into Prolific and the completion URL that
Prolific expects participants to be sent back to.

Prolific replaces ``{{%PROLIFIC_PID%}}``, ``{{%STUDY_ID%}}`` and ``{{%SESSION_ID%}}`` in the
study URL with each participant's IDs; the participant pages record them
(``app.web.participant.views.PROLIFIC_FIELDS``). A participant who finishes is sent to the
completion URL, ``https://app.prolific.com/submissions/complete?cc=<completion code>``, unless
the study file gives its own ``redirect_url``.
"""

from __future__ import annotations

from urllib.parse import quote

from app.web.models import Study

PROLIFIC_PARAMETERS = ("PROLIFIC_PID", "STUDY_ID", "SESSION_ID")
COMPLETION_BASE = "https://app.prolific.com/submissions/complete?cc="
#: How long the completion page shows the code before it sends the participant on.
REDIRECT_SECONDS = 5


def prolific_study_url(link: str) -> str:
    """The participant ``link`` with Prolific's placeholders, as Prolific's study URL.

    >>> prolific_study_url("https://x.org/s/abc")
    'https://x.org/s/abc?PROLIFIC_PID={{%PROLIFIC_PID%}}&STUDY_ID={{%STUDY_ID%}}&SESSION_ID={{%SESSION_ID%}}'
    """
    query = "&".join(f"{name}={{{{%{name}%}}}}" for name in PROLIFIC_PARAMETERS)
    return f"{link}{'&' if '?' in link else '?'}{query}"


def completion_url(study: Study) -> str:
    """Where a finished participant goes: the study's ``redirect_url``, else Prolific's
    completion URL with the study's code; "" when the study has neither."""
    if study.redirect_url:
        return study.redirect_url
    if study.completion_code:
        return COMPLETION_BASE + quote(study.completion_code, safe="")
    return ""


def participant_completion_url(study: Study, prolific_pid: str | None) -> str:
    """Where this finished participant is sent: the study's ``redirect_url``; else, for a
    participant who came from Prolific (``prolific_pid``), Prolific's completion URL with the
    code; else "" (the code is shown, nothing more)."""
    if study.redirect_url:
        return study.redirect_url
    if prolific_pid and study.completion_code:
        return completion_url(study)
    return ""
