"""``/p/<token>/audio-check``: the audio check before the first trial (the study file's
``[audio_check]``, ``app.web.study.audiocheck``). The trial page sends a participant who owes
it here; the page plays one question's three sounds (a WAV made for that question only) and
posts the answer; the server scores it."""

from __future__ import annotations

from flask import abort, make_response, redirect, render_template, request, url_for
from flask_wtf import FlaskForm

from app.stimuli.headphones import interval_onsets
from app.web.extensions import db
from app.web.participant.blueprint import bp
from app.web.participant.views import _no_store, _participant
from app.web.study import audiocheck


class AudioCheckForm(FlaskForm):
    """Only the CSRF token: the answer's fields are read from ``request.form``."""


def _number(name: str) -> int | None:
    value = request.form.get(name, "")
    return int(value) if value.isascii() and value.isdigit() and len(value) < 4 else None


@bp.route("/p/<token>/audio-check", methods=["GET", "POST"])
def audio_check(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    if not audiocheck.pending(participant):
        return redirect(url_for(".trial", token=token))
    spec = audiocheck.audio_spec(participant)
    if request.method == "POST":
        if not AudioCheckForm().validate_on_submit():
            abort(400)
        if request.form.get("retry"):
            audiocheck.retry(participant)
        else:
            attempt, question = _number("attempt"), _number("question")
            choice = _number("choice")
            try:
                audiocheck.answer(
                    participant, attempt=attempt or 0, question=question or 0, choice=choice
                )
            except audiocheck.AudioCheckRefused:
                db.session.rollback()
                return redirect(url_for(".audio_check", token=token))
        if not audiocheck.pending(participant):
            # The verdict, once: afterwards the check page leads on to the trials.
            passed = bool((participant.audio_check or {}).get("passed"))
            return _page(participant, spec, "done", passed=passed)
        db.session.commit()
        return redirect(url_for(".audio_check", token=token))
    current = audiocheck.begin(participant)
    attempt, question = audiocheck.position(participant)
    phase = audiocheck.phase(spec, current)
    return _page(participant, spec, phase, attempt=attempt, question=question)


def _page(participant, spec, phase: str, **context):  # type: ignore[no-untyped-def]
    """The check's page in ``phase`` (question, retry or done), rendered before the request's
    commit (which would expire the rows it reads)."""
    page = render_template(
        "participant/audio_check.html",
        participant=participant,
        study=participant.study,
        spec=spec,
        phase=phase,
        onsets=interval_onsets(),
        form=AudioCheckForm(),
        **context,
    )
    db.session.commit()
    return _no_store(page)


@bp.get("/p/<token>/audio-check/<int:attempt>-<int:question>.wav")
def audio_check_sound(token: str, attempt: int, question: int):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    body = audiocheck.sound(participant, attempt=attempt, question=question)
    if body is None:
        abort(404)
    response = make_response(body)
    response.headers["Content-Type"] = "audio/wav"
    # The question's sound is made anew for each request; nothing keeps a copy.
    response.headers["Cache-Control"] = "no-store"
    return response
