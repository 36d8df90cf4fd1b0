"""The participant's path through a study: ``/s/<slug>`` (the one public link) -> consent ->
``/p/<token>/instructions`` -> ``/p/<token>/trial`` (repeated) -> ``/p/<token>/done``.

The token is the participant's only credential; it lives in their URL and in a per-study
cookie, so reopening the study link resumes where they left off.
"""

from __future__ import annotations

import re
from typing import Any

import sqlalchemy as sa
from flask import (
    abort,
    g,
    make_response,
    redirect,
    render_template,
    request,
    url_for,
)
from flask_babel import lazy_gettext
from flask_wtf import FlaskForm
from markupsafe import Markup, escape
from sqlalchemy.exc import IntegrityError
from werkzeug.exceptions import TooManyRequests
from wtforms import HiddenField, SubmitField

from app.trials import rules
from app.trials.design import RATING_DESIGNS
from app.trials.participation import ParticipationSpec
from app.web.extensions import db
from app.web.infra import limits, throttle
from app.web.infra.i18n import use_language
from app.web.infra.limits import fits
from app.web.infra.media import media_response
from app.web.models import Participant, Study, Trial, utcnow
from app.web.participant.blueprint import bp
from app.web.study import audiocheck
from app.web.study.adaptive import ADAPTIVE
from app.web.study.enrolment import (
    SESSION_ENDED,
    dropped_after,
    enrol,
    practice_stimulus,
    touch_with_progress,
    unstarted_after,
)
from app.web.study.participants import ended_by_browser
from app.web.study.progress import next_trials
from app.web.study.ratings import shown_items
from app.web.study.studies import participation, rating_scale
from app.web.study.votes import SCREENED_OUT, replay_policy
from app.web.study.wording import (
    SIDE_NAMES,
    ended_reason,
    rating_levels,
    script_strings,
    translated_answers,
)

COOKIE_DAYS = 30
#: Clips never change under a URL (a re-render writes a new file and ETag), so the browser
#: may keep them for the length of a study: a preloaded next clip is served from its cache.
CLIP_CACHE_SECONDS = 7 * 86400
PROLIFIC_FIELDS = {
    "PROLIFIC_PID": "prolific_pid",
    "STUDY_ID": "prolific_study_id",
    "SESSION_ID": "prolific_session_id",
}


class ConsentForm(FlaskForm):
    PROLIFIC_PID = HiddenField()
    STUDY_ID = HiddenField()
    SESSION_ID = HiddenField()
    agree = SubmitField(lazy_gettext("I agree and want to take part"))


def _cookie_name(study: Study) -> str:
    return f"fp-{study.id}"


def _study(slug: str) -> Study:
    study = db.session.scalar(sa.select(Study).where(Study.slug == slug))
    if study is None or study.status in ("draft", "ready"):
        abort(404)
    use_language(participation(study).language)
    return study


def _participant(token: str) -> Participant:
    # Already read by the questionnaire guard before this view (``questionnaire_first``).
    found = g.get("participant")
    if found is not None and found in db.session and found.token == token:
        participant: Participant | None = found
    else:
        participant = db.session.scalar(sa.select(Participant).where(Participant.token == token))
    if participant is None:
        abort(404)
    use_language(participation(participant.study).language)
    return participant


@bp.app_template_global("script_strings")
def _script_strings(study: Study) -> dict[str, Any]:
    """The strings of the scripts of a page of ``study`` (``participant/layout.html``)."""
    max_plays = study.max_plays if study.replay == "max_plays" else None
    return script_strings(max_plays, rating=study.design in RATING_DESIGNS)


@bp.app_template_filter("paragraphs")
def paragraphs(text: str | None) -> Markup:
    """Study-file text as paragraphs: a blank line starts one, single line breaks (as a TOML
    multi-line string wraps) flow together, so the page is not ragged."""
    blocks = [" ".join(b.split()) for b in re.split(r"\n\s*\n", text or "") if b.strip()]
    return Markup("".join(f"<p>{escape(b)}</p>" for b in blocks))


def _with_cookie(response, study: Study, participant: Participant):  # type: ignore[no-untyped-def]
    return _set_cookie(response, _cookie_name(study), participant.token)


def _set_cookie(response, name: str, token: str):  # type: ignore[no-untyped-def]
    response.set_cookie(
        name,
        token,
        max_age=COOKIE_DAYS * 86400,
        httponly=True,
        samesite="Lax",
        secure=request.is_secure,
    )
    return response


def _by_prolific_id(study: Study, pid: str | None) -> Participant | None:
    if not pid or not fits(Participant.prolific_pid, pid):
        return None
    return db.session.scalar(
        sa.select(Participant).where(
            Participant.study_id == study.id, Participant.prolific_pid == pid
        )
    )


@bp.route("/s/<slug>", methods=["GET", "POST"])
def start(slug: str):  # type: ignore[no-untyped-def]
    study = _study(slug)
    token = request.cookies.get(_cookie_name(study))
    if token and fits(Participant.token, token):
        known = db.session.scalar(
            sa.select(Participant).where(
                Participant.token == token, Participant.study_id == study.id
            )
        )
        if known is not None:
            return redirect(url_for(".resume", token=known.token))
    # One Prolific ID takes part once. Its second arrival resumes the first only with what
    # only that participant has: this browser's cookie (above) or Prolific's per-attempt
    # SESSION_ID as stored. A Prolific ID alone is no credential: anyone may type one.
    known = _by_prolific_id(study, request.values.get("PROLIFIC_PID"))
    if known is not None:
        return _resume_known(study, known, request.values.get("SESSION_ID"))
    if study.status != "open":
        return render_template("participant/unavailable.html", study=study), 503
    form = ConsentForm(data={k: request.args.get(k, "") for k in PROLIFIC_FIELDS})
    if form.validate_on_submit():
        ids = {
            column: (getattr(form, field).data or None) for field, column in PROLIFIC_FIELDS.items()
        }
        agent = limits.printable(request.user_agent.string)[:300]
        # Counted first, in one atomic step that decides (in this transaction when the count
        # is kept in the database, so a consent that fails takes its count back with it).
        wait = throttle.count_consent(slug, request.remote_addr or "unknown")
        if wait is not None:
            db.session.rollback()
            raise TooManyRequests(retry_after=wait)
        try:
            participant = enrol(
                study,
                user_agent=agent,
                dropped_after=dropped_after(),
                unstarted=unstarted_after(),
                **ids,
            )
            # Read before the commit expires them: afterwards each was a query of its own.
            token, cookie = participant.token, _cookie_name(study)
            db.session.commit()
            answer = make_response(redirect(url_for(".resume", token=token)))
            return _set_cookie(answer, cookie, token)
        except IntegrityError:
            # The same ID enrolled at the same moment in another tab: resume that one.
            db.session.rollback()
            study = db.session.get(Study, study.id)  # type: ignore[assignment]
            participant = _by_prolific_id(study, ids["prolific_pid"])  # type: ignore[assignment]
            if participant is None:  # pragma: no cover - the constraint fired, so it exists
                raise
        return _resume_known(study, participant, ids["prolific_session_id"])
    return render_template("participant/consent.html", study=study, form=form)


@bp.errorhandler(429)
def too_many_consents(error: Any):  # type: ignore[no-untyped-def]
    """The consent limits (:mod:`app.web.infra.throttle`): a page that says to wait, with
    Retry-After, in the study's language."""
    slug = (request.view_args or {}).get("slug")
    if isinstance(slug, str) and fits(Study.slug, slug):
        study = db.session.scalar(sa.select(Study).where(Study.slug == slug))
        if study is not None:
            use_language(participation(study).language)
    response = make_response(render_template("participant/busy.html"), 429)
    response.headers["Cache-Control"] = "no-store"
    wait = getattr(error, "retry_after", None)
    if wait is not None:
        response.headers["Retry-After"] = str(wait)
    return response


def resumes(participant: Participant, session_id: str | None) -> bool:
    """Whether an arrival with this participant's Prolific ID and ``session_id`` (Prolific's
    per-attempt ``SESSION_ID``) may take over the participant without the study's cookie:
    only with the same, non-empty session ID as stored at consent."""
    stored = participant.prolific_session_id
    return bool(stored) and session_id == stored


def _resume_known(study: Study, participant: Participant, session_id: str | None):  # type: ignore[no-untyped-def]
    if resumes(participant, session_id):
        return _with_cookie(
            redirect(url_for(".resume", token=participant.token)), study, participant
        )
    # Nothing handed over: no link, no cookie; the page says what to do instead.
    return _no_store(render_template("participant/already_started.html", study=study)), 409


@bp.get("/p/<token>")
def resume(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    if ended_by_browser(participant):
        return redirect(url_for(".unplayable", token=token))
    if participant.finished_at is not None or participant.screened_out_at is not None:
        return redirect(url_for(".done", token=token))
    if participant.started_at is None:
        return redirect(url_for(".instructions", token=token))
    return redirect(url_for(".trial", token=token))


@bp.get("/p/<token>/instructions")
def instructions(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    if participant.started_at is not None or ended_by_browser(participant):
        # The back button after a vote: the practice is over, the study goes on.
        return redirect(url_for(".resume", token=token))
    practice = practice_stimulus(participant)
    study = participant.study
    spec = participation(study)
    return _no_store(
        render_template(
            "participant/instructions.html",
            participant=participant,
            study=study,
            practice=practice,
            spec=spec,
            scale=rating_scale(study) if study.design in RATING_DESIGNS else None,
            **player_settings(study, spec),
        )
    )


def player_settings(study: Study, spec: ParticipationSpec) -> dict[str, Any]:
    """What the player template and script take from :mod:`app.trials.rules`: the answer
    buttons, the keys that cast a choice, the replay policy."""
    answers = rules.answers(
        scale=spec.scale,
        undecided_allowed=study.allow_undecided,
        undecided_label=study.undecided_label,
    )
    default_label = study.undecided_label == rules.DEFAULT_UNDECIDED_LABEL
    return {
        "answers": translated_answers(answers),
        # A label the study file wrote (its own undecided label) is the study's text.
        "study_labels": () if default_label else (study.undecided_label,),
        "answer_keys": rules.key_map(spec.scale),
        "replay": replay_policy(study),
        "side_names": SIDE_NAMES,
    }


def _no_store(body: str):  # type: ignore[no-untyped-def]
    """A page the back button must fetch again rather than show from memory (a trial that
    was answered, the practice after the start)."""
    response = make_response(body)
    response.headers["Cache-Control"] = "no-store"
    return response


@bp.get("/p/<token>/trial")
def trial(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    study = participant.study
    if ended_by_browser(participant):
        return redirect(url_for(".unplayable", token=token))
    if participant.screened_out_at is not None:
        return redirect(url_for(".done", token=token))
    if participant.started_at is None and audiocheck.pending(participant):
        return redirect(url_for(".audio_check", token=token))
    if study.status == "closed":
        return render_template("participant/unavailable.html", study=study), 410
    spec = participation(study)
    environment = participant.environment or {}
    if spec.min_face_px and environment.get("viewing_ok") is False:
        return render_template(
            "participant/unavailable.html", study=study, viewing=spec.min_face_px
        ), 409
    # The unanswered trial after this one comes along: its clip is preloaded while this
    # one is judged.
    upcoming, following = (next_trials(participant, 2) + [None, None])[:2]
    if study.design == ADAPTIVE:  # its pair is chosen at the vote before it: not yet known
        following = None
    if upcoming is None:
        return redirect(url_for(".done", token=token))
    counts = touch_with_progress(participant)
    if counts is None:
        db.session.commit()
        return render_template(
            "participant/unavailable.html", study=study, reason=ended_reason(SESSION_ENDED)
        ), 410
    if participant.started_at is None:
        participant.started_at = utcnow()
    answered, total = counts
    # Rendered before the commit, which expires every loaded row: rendering after it would
    # read the participant, study and trials again.
    if study.design in RATING_DESIGNS:
        template = f"participant/{'parallel' if study.design == 'parallel' else 'rating'}.html"
        shown: dict[str, Any] = {
            "scale": rating_scale(study),
            "levels": rating_levels(),
            "replay": replay_policy(study),
        }
        if study.design == "parallel":
            shown["items"] = len(shown_items(participant, upcoming))
        else:  # one face a trial: the next one's clip is preloaded, as the next pair's is
            shown["following"] = following
    else:
        template = "participant/trial.html"
        shown = {
            "following": following,
            "instructed": rules.instructed_side(
                upcoming.kind, upcoming.expected, lambda: upcoming.stimulus.instruction
            ),
            **player_settings(study, spec),
        }
    page = render_template(
        template,
        participant=participant,
        study=study,
        trial=upcoming,
        answered=answered,
        total=total,
        spec=spec,
        **shown,
    )
    db.session.commit()
    return _no_store(page)


def _own_trial(token: str, trial_id: int) -> tuple[Participant, Trial, str]:
    """The participant, one of their trials (404 for anyone else's) and the opaque name its
    clip is sent under, without extension (``pair-03``, ``clip-03``, ``practice``)."""
    participant = _participant(token)
    trial = db.session.get(Trial, trial_id)
    if trial is None or trial.participant_id != participant.id:
        abort(404)
    shows = "clip" if participant.study.design in RATING_DESIGNS else "pair"
    name = "practice" if trial.kind == "practice" else f"{shows}-{trial.position + 1:02d}"
    return participant, trial, name


@bp.get("/p/<token>/video/<int:trial_id>")
def video(token: str, trial_id: int):  # type: ignore[no-untyped-def]
    participant, trial, name = _own_trial(token, trial_id)
    return _send_video(participant.study, trial.stimulus.video_path, f"{name}.mp4")


@bp.get("/p/<token>/practice.mp4")
def practice_video(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    stimulus = practice_stimulus(participant)
    if stimulus is None:
        abort(404)
    return _send_video(participant.study, stimulus.video_path, "practice.mp4")


def _send_video(study: Study, rel: str | None, name: str, mimetype: str = "video/mp4"):  # type: ignore[no-untyped-def]
    # Blinding: the browser is told only the pair's place in this participant's schedule,
    # never the stored name (docs/reference/web.md, "Blinding"); the caller checked the clip is in
    # this participant's schedule (app.web.infra.media sends it, never first).
    return media_response(
        study, rel, mimetype=mimetype, cache_seconds=CLIP_CACHE_SECONDS, download_name=name
    )


@bp.get("/p/<token>/done")
def done(token: str):  # type: ignore[no-untyped-def]
    participant = _participant(token)
    screened = participant.screened_out_at is not None
    # Only after the server holds every vote: finished_at is set by the last one stored.
    if participant.finished_at is None and not screened:
        return redirect(url_for(".resume", token=token))
    study = participant.study
    code = participation(study).screened_out_code if screened else study.completion_code
    return _no_store(
        render_template(
            "participant/done.html",
            participant=participant,
            study=study,
            screened=screened,
            code=code,
            reason=ended_reason(SCREENED_OUT) if screened else None,
        )
    )
