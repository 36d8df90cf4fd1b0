"""The participant's path through a study: ``/s/<slug>`` (the one public link) -> consent ->
``/p/<token>/instructions`` -> ``/p/<token>/trial`` (repeated) -> ``/p/<token>/done``.

The token is the participant's only credential; it lives in their URL and in a per-study
cookie, so reopening the study link resumes where they left off.
"""

from __future__ import annotations

import sqlalchemy as sa
from flask import (
    Blueprint,
    abort,
    make_response,
    redirect,
    render_template,
    request,
    send_file,
    url_for,
)
from flask_wtf import FlaskForm
from wtforms import HiddenField, SubmitField

from app import limits
from app.enrolment import (
    SESSION_ENDED,
    dropped_after,
    enrol,
    next_trial,
    practice_stimulus,
    progress,
    touch,
)
from app.extensions import db
from app.limits import fits
from app.models import Participant, Study, Trial, utcnow
from app.storage import media_file

bp = Blueprint("participant", __name__)

COOKIE_DAYS = 30
PROLIFIC_FIELDS = {"PROLIFIC_PID": "prolific_pid", "STUDY_ID": "prolific_study_id",
                   "SESSION_ID": "prolific_session_id"}


class ConsentForm(FlaskForm):
    PROLIFIC_PID = HiddenField()
    STUDY_ID = HiddenField()
    SESSION_ID = HiddenField()
    agree = SubmitField("I agree and want to take part")


def _cookie_name(study: Study) -> str:
    return f"fp-{study.id}"


def _study(slug: str) -> Study:
    study = db.session.scalar(sa.select(Study).where(Study.slug == slug))
    if study is None or study.status in ("draft", "ready"):
        abort(404)
    return study


def _participant(token: str) -> Participant:
    participant = db.session.scalar(sa.select(Participant).where(Participant.token == token))
    if participant is None:
        abort(404)
    return participant


@bp.route("/s/<slug>", methods=["GET", "POST"])
def start(slug: str):  # type: ignore[no-untyped-def]
    study = _study(slug)
    token = request.cookies.get(_cookie_name(study))
    if token and fits(Participant.token, token):
        known = db.session.scalar(sa.select(Participant).where(
            Participant.token == token, Participant.study_id == study.id))
        if known is not None:
            return redirect(url_for(".resume", token=known.token))
    if study.status != "open":
        return render_template("participant/unavailable.html", study=study), 503
    form = ConsentForm(data={k: request.args.get(k, "") for k in PROLIFIC_FIELDS})
    if form.validate_on_submit():
        ids = {column: (getattr(form, field).data or None) for field, column
               in PROLIFIC_FIELDS.items()}
        agent = limits.printable(request.user_agent.string)[:300]
        participant = enrol(study, user_agent=agent, dropped_after=dropped_after(), **ids)
        db.session.commit()
        response = make_response(redirect(url_for(".instructions", token=participant.token)))
        response.set_cookie(_cookie_name(study), participant.token, max_age=COOKIE_DAYS * 86400,
                            httponly=True, samesite="Lax", secure=request.is_secure)
        return response
    return render_template("participant/consent.html", study=study, form=form)


@bp.get("/p/<token>")
def resume(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    if participant.finished_at is not None:
        return redirect(url_for(".done", token=token))
    if participant.started_at is None:
        return redirect(url_for(".instructions", token=token))
    return redirect(url_for(".trial", token=token))


@bp.get("/p/<token>/instructions")
def instructions(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    practice = practice_stimulus(participant)
    return render_template("participant/instructions.html", participant=participant,
                           study=participant.study, practice=practice)


@bp.get("/p/<token>/trial")
def trial(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    study = participant.study
    if study.status == "closed":
        return render_template("participant/unavailable.html", study=study), 410
    upcoming = next_trial(participant)
    if upcoming is None:
        return redirect(url_for(".done", token=token))
    if not touch(participant):
        db.session.commit()
        return render_template("participant/unavailable.html", study=study,
                               reason=SESSION_ENDED), 410
    if participant.started_at is None:
        participant.started_at = utcnow()
    answered, total = progress(participant)
    db.session.commit()
    return render_template("participant/trial.html", participant=participant, study=study,
                           trial=upcoming, answered=answered, total=total)


@bp.get("/p/<token>/video/<int:trial_id>")
def video(token: str, trial_id: int):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    trial = db.session.get(Trial, trial_id)
    if trial is None or trial.participant_id != participant.id:
        abort(404)
    return _send_video(participant.study, trial.stimulus.video_path)


@bp.get("/p/<token>/practice.mp4")
def practice_video(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    stimulus = practice_stimulus(participant)
    if stimulus is None:
        abort(404)
    return _send_video(participant.study, stimulus.video_path)


def _send_video(study: Study, rel: str | None):  # type: ignore[no-untyped-def]
    if not rel:
        abort(404)
    path = media_file(study, rel)
    if not path.is_file():
        abort(404)
    # Range requests (conditional=True) let the browser seek and replay without refetching;
    # the URL names no condition, so the file name cannot give the answer away.
    response = send_file(path, mimetype="video/mp4", conditional=True, max_age=3600)
    response.headers["Cache-Control"] = "private, max-age=3600"
    return response


@bp.get("/p/<token>/done")
def done(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    if participant.finished_at is None:
        return redirect(url_for(".resume", token=token))
    return render_template("participant/done.html", participant=participant,
                           study=participant.study)
