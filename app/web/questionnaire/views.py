"""``/p/<token>/questions/<page>``: a questionnaire page of the study
(``app.web.study.questionnaires``).

The participant's path passes through it by itself: a request for the instructions or a trial
while the ``before`` page is owed, or for the completion page while the ``after`` page is owed,
is sent here first (:func:`questionnaire_first`, installed by ``app.web``).
"""

from __future__ import annotations

from functools import cache

import sqlalchemy as sa
from flask import abort, g, redirect, render_template, request, url_for
from flask_babel import gettext as _
from flask_wtf import FlaskForm
from sqlalchemy import orm as so

from app.trials.questions import PAGES, AnswerError, check_answer
from app.web.extensions import db
from app.web.infra.i18n import use_language
from app.web.infra.limits import fits
from app.web.models import Participant
from app.web.questionnaire.blueprint import bp
from app.web.study.questionnaires import pending_page, save_answers, study_questions
from app.web.study.studies import participation
from app.web.study.wording import question_words


@bp.app_template_filter("bound")
def bound(value: float) -> str:
    """A number question's bound as the page shows it: 24, not 24.0."""
    return f"{value:g}"


#: Participant pages that wait for an owed questionnaire page, and which page each waits for.
_GUARDED = {
    "participant.instructions": "before",
    "participant.trial": "before",
    "participant.done": "after",
}


def questionnaire_first():  # type: ignore[no-untyped-def]
    """Before a guarded participant page: the owed questionnaire page, if any."""
    wanted = _GUARDED.get(request.endpoint or "")
    token = (request.view_args or {}).get("token")
    if wanted is None or not isinstance(token, str) or not fits(Participant.token, token):
        return None
    participant = db.session.scalar(_with_study(), {"token": token})
    if participant is None:
        return None
    g.participant = participant  # the view reads it again otherwise (two queries a page)
    page = pending_page(participant)
    if page is None or (page == "after") != (wanted == "after"):
        return None
    return redirect(url_for("questionnaire.page", token=token, page=page))


@cache
def _with_study() -> sa.Select[tuple[Participant]]:
    """The participant of a token with their study, which the guard and the page read next
    (a lazy load of the study was a second query on every trial page); built once."""
    return (
        sa.select(Participant)
        .where(Participant.token == sa.bindparam("token"))
        .options(so.joinedload(Participant.study))
    )


def answer_problem(error: AnswerError) -> str:
    """What the participant reads under a refused answer, in the page's language."""
    limit, got = (f"{error.limit:g}" if error.limit is not None else ""), error.got
    if error.problem == "required":
        return _("an answer is required")
    if error.problem == "choice":
        return _("choose one of the options, got %(got)s", got=got)
    if error.problem == "number":
        return _("expected a number, got %(got)s", got=got)
    if error.problem == "minimum":
        return _("must be at least %(limit)s, got %(got)s", limit=limit, got=got)
    if error.problem == "maximum":
        return _("must be at most %(limit)s, got %(got)s", limit=limit, got=got)
    if error.problem == "length":
        return _("at most %(limit)s characters, got %(got)s", limit=limit, got=got)
    return error.message


class _PageForm(FlaskForm):
    """Only the CSRF token: the questions are the study's, read from ``request.form``."""


@bp.route("/p/<token>/questions/<page>", methods=["GET", "POST"])
def page(token: str, page: str):  # type: ignore[no-untyped-def]
    participant = db.session.scalar(sa.select(Participant).where(Participant.token == token))
    if participant is None or page not in PAGES:
        abort(404)
    use_language(participation(participant.study).language)
    questions = study_questions(participant.study, page)
    if pending_page(participant) != page:
        return redirect(url_for("participant.resume", token=token))
    form = _PageForm()
    errors: dict[str, str] = {}
    values = {q.name: request.form.get(q.name, "") for q in questions}
    if request.method == "POST":
        if not form.validate_on_submit():
            abort(400)
        answers = {}
        for question in questions:
            try:
                answers[question.name] = check_answer(question, values[question.name])
            except AnswerError as exc:
                errors[question.name] = answer_problem(exc)
        if not errors:
            save_answers(participant, page, answers)
            db.session.commit()
            target = "participant.done" if page == "after" else "participant.instructions"
            return redirect(url_for(target, token=token))
    return render_template(
        "questionnaire/page.html",
        study=participant.study,
        participant=participant,
        page=page,
        questions=questions,
        words={q.name: question_words(q) for q in questions},
        values=values,
        errors=errors,
        form=form,
    ), 400 if errors else 200
