"""The clips' WebM rendition on the participant's side, and the end of a session whose browser
plays no rendition (docs/reference/web.md, "Renditions").

Every page that plays a clip offers its MP4 and, where the stimulus has one, its WebM (VP9 +
Opus); ``static/participant.js`` plays the first the browser can. The WebM is served as the
MP4 is: only a clip of this participant's schedule, named by its place in it. A browser that
can play neither is sent to :func:`unplayable`, the final page, once the API has ended the
session (``POST /api/v1/participants/<token>/unplayable``).
"""

from __future__ import annotations

from flask import abort, redirect, render_template, url_for

from app.web.models import Trial
from app.web.participant.blueprint import bp
from app.web.participant.views import _no_store, _own_trial, _participant, _send_video
from app.web.study.enrolment import practice_stimulus
from app.web.study.participants import ended_by_browser
from app.web.study.renditions import versions_have_webm

WEBM = "video/webm"


@bp.app_template_global("webm_url")
def webm_url(trial: Trial | None) -> str | None:
    """The URL of ``trial``'s WebM, or None where its clip has none (or there is no trial)."""
    if trial is None or not trial.stimulus.webm_path:
        return None
    return url_for("participant.video_webm", token=trial.participant.token, trial_id=trial.id)


@bp.app_template_global("items_webm")
def items_webm(trial: Trial) -> bool:
    """Whether every version of a ``parallel`` trial's clip has its WebM."""
    return versions_have_webm(trial.stimulus.clip_id)


@bp.get("/p/<token>/webm/<int:trial_id>")
def video_webm(token: str, trial_id: int):  # type: ignore[no-untyped-def]
    """The WebM of one of the participant's trials (as ``participant.video`` sends the MP4)."""
    participant, trial, name = _own_trial(token, trial_id)
    return _send_video(participant.study, trial.stimulus.webm_path, f"{name}.webm", WEBM)


@bp.get("/p/<token>/practice.webm")
def practice_webm(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    stimulus = practice_stimulus(participant)
    if stimulus is None:
        abort(404)
    return _send_video(participant.study, stimulus.webm_path, "practice.webm", WEBM)


@bp.get("/p/<token>/unplayable")
def unplayable(token: str):  # type: ignore[no-untyped-def]
    """The final page of a participant whose browser played none of the clips: which browsers
    work, and that their place went to someone else; any other participant goes on."""
    participant = _participant(token)
    if not ended_by_browser(participant):
        return redirect(url_for("participant.resume", token=token))
    page = render_template("participant/unavailable.html", study=participant.study, unplayable=True)
    return _no_store(page)
