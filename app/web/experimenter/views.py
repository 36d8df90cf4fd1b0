"""Experimenter pages under ``/experimenter``: each experimenter sees only their own studies."""

from __future__ import annotations

import secrets
from collections.abc import Callable
from typing import Any

import sqlalchemy as sa
from flask import (
    Response,
    abort,
    current_app,
    flash,
    make_response,
    redirect,
    render_template,
    request,
    session,
    url_for,
)
from itsdangerous import BadSignature, URLSafeSerializer, URLSafeTimedSerializer
from werkzeug.utils import secure_filename

from app.errors import InputError
from app.trials.design import RATING_DESIGNS
from app.trials.questions import PAGES
from app.web.experimenter.access import own_study
from app.web.experimenter.blueprint import bp
from app.web.experimenter.forms import (
    ActionForm,
    ConfirmForm,
    DeleteParticipantForm,
    DeleteStudyForm,
    DuplicateForm,
    LoginForm,
    PasswordForm,
    ShareForm,
)
from app.web.experimenter.lifecycle import shares_of
from app.web.experimenter.participants import monitor_table
from app.web.extensions import db, limiter
from app.web.infra.accounts import (
    authenticate,
    change_password,
    current_user,
    end_login,
    end_logins,
    login_required,
    start_login,
    study_access,
)
from app.web.infra.media import media_response
from app.web.infra.security import REPORT_CONTENT_SECURITY_POLICY, safe_next
from app.web.infra.storage import media_file, report_path
from app.web.jobs import EnqueueError, enqueue
from app.web.jobs.bodies import JOB_KINDS
from app.web.jobs.sweep import sweep_study_jobs
from app.web.models import Job, Stimulus, Study, StudyShare
from app.web.study.enrolment import dropped_after, release_dropped, unstarted_after
from app.web.study.exports import ratings_csv, votes_csv
from app.web.study.monitor import study_monitor
from app.web.study.participants import release_pilots
from app.web.study.privacy import delete_participants, participants_csv
from app.web.study.questionnaires import study_questions
from app.web.study.recruitment import completion_url, prolific_study_url
from app.web.study.studies import change_status as apply
from app.web.study.studies import participation, stimuli_locked


@bp.before_request
def _load_user() -> None:
    current_user()  # sets g.user for the templates


def _account_limits() -> str:
    return current_app.config["LOGIN_LIMIT_PER_ACCOUNT"]


def _address_limits() -> str:
    return current_app.config["LOGIN_LIMIT_PER_ADDRESS"]


#: A browser that has logged in to an account before carries a signed device cookie for it
#: (OWASP's "device cookies" against lock-out): its failed logins count in a bucket of their
#: own, so an attacker who exhausts an address's or an account's limit does not lock out the
#: experimenter on their own computer.
DEVICE_COOKIE = "fp-device"
DEVICE_DAYS = 180


def _device_serializer() -> URLSafeSerializer:
    return URLSafeSerializer(current_app.secret_key, salt="facepair-login-device")


def _known_device() -> str | None:
    """The id of this browser's device cookie, if it was issued for the e-mail being tried."""
    raw = request.cookies.get(DEVICE_COOKIE)
    if not raw:
        return None
    try:
        data = _device_serializer().loads(raw)
    except BadSignature:
        return None
    email = request.form.get("email", "").strip().lower()
    if isinstance(data, dict) and data.get("email") == email and isinstance(data.get("id"), str):
        return data["id"]
    return None


def _login_account() -> str:
    account = "account:" + request.form.get("email", "").strip().lower()[:200]
    device = _known_device()
    return f"{account}:device:{device}" if device else account


def _login_address() -> str:
    device = _known_device()
    return f"device:{device}" if device else "address:" + (request.remote_addr or "unknown")


def _remember_device(response: Response, email: str, device: str | None = None) -> Response:
    device = device or secrets.token_urlsafe(12)
    value = _device_serializer().dumps({"email": email, "id": device})
    response.set_cookie(
        DEVICE_COOKIE,
        value,
        max_age=DEVICE_DAYS * 86400,
        httponly=True,
        samesite="Lax",
        secure=request.is_secure,
        path=url_for(".login"),
    )
    return response


#: How long an unlock link (``facepair experimenter unlock``) may be opened.
UNLOCK_MINUTES = 60


def _unlock_serializer() -> URLSafeTimedSerializer:
    return URLSafeTimedSerializer(current_app.secret_key, salt="facepair-login-unlock")


def unlock_token(email: str) -> str:
    """The token of an unlock link for the experimenter ``email``: opened in a browser, it
    gives that browser a device cookie for the account (its failed logins then count in a
    bucket of their own), the way out for an owner whose account or address an attacker's
    failures hold at 429. It logs no one in: the password is still needed. Every opening of
    one link gives the same device, so a leaked link is one more bucket, not many (OWASP
    Authentication Cheat Sheet, "Account Lockout"; ASVS 4.0, 2.2.1)."""
    return _unlock_serializer().dumps({"email": email, "id": secrets.token_urlsafe(12)})


def _unlocked(token: str) -> tuple[str, str] | None:
    """The account and device an unlock link's ``token`` names, said in a flashed message;
    None (and a message saying so) if it is not valid or has expired."""
    try:
        data = _unlock_serializer().loads(token, max_age=UNLOCK_MINUTES * 60)
    except BadSignature:
        data = None
    email = data.get("email") if isinstance(data, dict) else None
    device = data.get("id") if isinstance(data, dict) else None
    if not isinstance(email, str) or not isinstance(device, str):
        flash("This unlock link is not valid or has expired; ask for a new one.", "error")
        return None
    flash(f"This browser may now log in as {email}: others' failed logins no longer hold it.")
    return email, device


def _login_failed(response: Response) -> bool:
    # Only failed attempts count: a successful login redirects.
    return response.status_code != 302


@bp.route("/login", methods=["GET", "POST"])
@limiter.limit(
    _account_limits,
    key_func=_login_account,
    methods=["POST"],
    deduct_when=_login_failed,
    scope="login-account",
)
@limiter.limit(
    _address_limits,
    key_func=_login_address,
    methods=["POST"],
    deduct_when=_login_failed,
    scope="login-address",
)
def login():  # type: ignore[no-untyped-def]
    form = LoginForm()
    if form.validate_on_submit():
        user = authenticate(form.email.data or "", form.password.data or "")
        if user is not None:
            start_login(user)
            db.session.commit()
            # Only paths on this site: an open redirect would hand the login to another site.
            answer = redirect(safe_next(request.args.get("next"), url_for(".studies")))
            return _remember_device(answer, user.email)
        flash("Unknown e-mail or wrong password.", "error")
    token = request.args.get("unlock") if request.method == "GET" else None
    unlocked = _unlocked(token[:500]) if token else None
    page = make_response(render_template("experimenter/login.html", form=form))
    return _remember_device(page, *unlocked) if unlocked else page


@bp.errorhandler(429)
def too_many_logins(error: Any):  # type: ignore[no-untyped-def]
    """The login limits: the login page again, saying to wait, and what an owner whose own
    browser is held can do (an unlock link from whoever runs the site)."""
    flash(
        "Too many failed logins for this account or from this network; try again later. "
        "If this is your account, whoever runs this site can give you an unlock link "
        "(facepair experimenter unlock).",
        "error",
    )
    return render_template("experimenter/login.html", form=LoginForm()), 429


@bp.post("/logout")
def logout():  # type: ignore[no-untyped-def]
    if ActionForm().validate_on_submit():
        end_login()
    return redirect(url_for(".login"))


@bp.get("/account")
@login_required
def account():  # type: ignore[no-untyped-def]
    return render_template(
        "experimenter/account.html", form=PasswordForm(), everywhere=ActionForm()
    )


@bp.post("/account/password")
@login_required
def account_password():  # type: ignore[no-untyped-def]
    form = PasswordForm()
    user = current_user()
    assert user is not None  # login_required
    if form.validate_on_submit():
        if not user.check_password(form.current.data or ""):
            flash("current password: not the account's password.", "error")
        else:
            try:
                ended = change_password(user, form.password.data or "")
            except InputError as exc:
                flash(f"{exc}.", "error")
            else:
                db.session.commit()
                flash(f"Password changed; {ended} other login(s) ended.", "info")
                return redirect(url_for(".account"))
    status = 400
    return render_template("experimenter/account.html", form=form, everywhere=ActionForm()), status


@bp.post("/account/logout-everywhere")
@login_required
def logout_everywhere():  # type: ignore[no-untyped-def]
    user = current_user()
    if ActionForm().validate_on_submit() and user is not None:
        end_logins(user)
        session.clear()
    return redirect(url_for(".login"))


@bp.get("/")
@login_required
def studies():  # type: ignore[no-untyped-def]
    user = current_user()

    shared = sa.select(StudyShare.study_id).where(StudyShare.user_id == user.id)  # type: ignore[union-attr]
    rows = db.session.scalars(
        sa.select(Study)
        .where(sa.or_(Study.owner_id == user.id, Study.id.in_(shared)))  # type: ignore[union-attr]
        .order_by(Study.created_at.desc())
    ).all()
    return render_template("experimenter/studies.html", studies=rows, action=ActionForm())


def _start(study: Study, kind: str) -> None:
    """A new job row, committed, then handed to the runner; if the runner cannot take it the
    row goes again (no orphan row) and the experimenter reads why."""

    job = Job(study_id=study.id, kind=kind)
    db.session.add(job)
    db.session.commit()
    try:
        # After the commit: the worker must find the row.
        enqueue(current_app._get_current_object(), job.id)  # type: ignore[attr-defined]
    except EnqueueError as exc:
        db.session.delete(job)
        db.session.commit()
        flash(
            f"The {kind} job could not be started: {exc}. Nothing was queued; try again "
            "once the job queue is back.",
            "error",
        )


@bp.get("/studies/<int:study_id>")
@login_required
def study(study_id: int):  # type: ignore[no-untyped-def]
    study = own_study(study_id)
    sweep_study_jobs(study.id)  # so the page never shows a dead job running
    jobs = db.session.scalars(
        sa.select(Job).where(Job.study_id == study.id).order_by(Job.id.desc()).limit(10)
    ).all()
    stimuli = db.session.scalars(
        sa.select(Stimulus).where(Stimulus.study_id == study.id).order_by(Stimulus.id)
    ).all()
    link = url_for("participant.start", slug=study.slug, _external=True)
    return render_template(
        "experimenter/study.html",
        study=study,
        jobs=jobs,
        stimuli=stimuli,
        link=link,
        action=ActionForm(),
        forget=DeleteParticipantForm(),
        **_study_extras(study, link),
    )


def _study_extras(study: Study, link: str) -> dict[str, object]:
    """The study page's lifecycle, recruitment and sharing parts."""

    access = study_access(study, current_user().id)  # type: ignore[union-attr]
    return {
        "access": access,
        "locked": stimuli_locked(study),
        "pilot_link": url_for(".pilot", token=study.pilot_token, _external=True),
        "part": participation(study),
        "questions": {page: study_questions(study, page) for page in PAGES},
        "prolific_url": prolific_study_url(link),
        "completion_url": completion_url(study),
        "confirm": ConfirmForm(),
        "duplicate_form": DuplicateForm(),
        "delete_form": DeleteStudyForm(),
        "share_form": ShareForm(),
        "shares": shares_of(study) if access == "owner" else [],
    }


@bp.post("/studies/<int:study_id>/jobs/<kind>")
@login_required
def start_job(study_id: int, kind: str):  # type: ignore[no-untyped-def]

    study = own_study(study_id, "full")
    if kind not in JOB_KINDS or not ActionForm().validate_on_submit():
        abort(400)
    locked = stimuli_locked(study) if kind in ("generate", "render") else None
    if locked:
        flash(f"Nothing started: {locked}.", "error")
    else:
        _start(study, kind)
    return redirect(url_for(".study", study_id=study.id))


@bp.post("/studies/<int:study_id>/jobs/<int:job_id>/retry")
@login_required
def retry_job(study_id: int, job_id: int):  # type: ignore[no-untyped-def]
    """Run a failed job again; a render resumes from the clips already rendered."""
    study = own_study(study_id, "full")
    job = db.session.get(Job, job_id)
    if job is None or job.study_id != study.id or not ActionForm().validate_on_submit():
        abort(404)
    if job.status != "failed":
        flash(f"Only a failed job can be retried (this one is {job.status}).", "error")
    else:
        _start(study, job.kind)
    return redirect(url_for(".study", study_id=study.id))


@bp.post("/studies/<int:study_id>/status/<action>")
@login_required
def change_status(study_id: int, action: str):  # type: ignore[no-untyped-def]

    study = own_study(study_id, "full")
    if not ActionForm().validate_on_submit():
        abort(400)
    if action == "reopen":  # only with its confirmation (``lifecycle.reopen``)
        abort(400)
    if action == "open" and any(
        s.video_path is None
        for s in db.session.scalars(sa.select(Stimulus).where(Stimulus.study_id == study.id))
    ):
        flash("Render the clips before opening recruitment.", "error")
        return redirect(url_for(".study", study_id=study.id))
    try:
        apply(study, action)
        if action == "open":
            release_pilots(study)
    except ValueError as exc:
        flash(str(exc), "error")
        return redirect(url_for(".study", study_id=study.id))
    db.session.commit()
    if action == "close":  # the report is regenerated when the study closes
        _start(study, "report")
    return redirect(url_for(".study", study_id=study.id))


@bp.get("/studies/<int:study_id>/monitor")
@login_required
def monitor(study_id: int):  # type: ignore[no-untyped-def]

    study = own_study(study_id)
    release_dropped(study, after=dropped_after(), unstarted_after=unstarted_after())
    db.session.commit()
    stats = study_monitor(study, dropped_after=dropped_after())

    return render_template(
        "experimenter/monitor.html", study=study, stats=stats, **monitor_table(study)
    )


@bp.get("/studies/<int:study_id>/votes.csv")
@login_required
def export_votes(study_id: int):  # type: ignore[no-untyped-def]
    return _answers_csv(study_id, votes_csv, "votes")


@bp.get("/studies/<int:study_id>/ratings.csv")
@login_required
def export_ratings(study_id: int):  # type: ignore[no-untyped-def]
    """The rating design's ratings (``app.analysis.rating_results.RATING_COLUMNS``)."""
    return _answers_csv(study_id, ratings_csv, "ratings")


def _answers_csv(study_id: int, export: Callable[..., str], kind: str):  # type: ignore[no-untyped-def]
    """A study's votes or ratings as a CSV download; ``?pilot=with|only`` for the pilots'."""
    study = own_study(study_id)
    pilot = request.args.get("pilot", "without")
    if pilot not in ("without", "with", "only"):
        pilot = "without"
    name = (secure_filename(study.title) or f"study-{study.id}") + (
        "" if pilot == "without" else f"-{pilot}-pilot"
    )
    return Response(
        export(study, pilot=pilot),
        mimetype="text/csv",
        headers={
            "Content-Disposition": f'attachment; filename="{name}-{kind}.csv"',
            "Cache-Control": "no-store",
        },
    )


@bp.get("/studies/<int:study_id>/participants.csv")
@login_required
def export_participants(study_id: int):  # type: ignore[no-untyped-def]
    """Participants with pseudonymised Prolific IDs; ``?ids=raw`` for the real ones (payment)."""

    study = own_study(study_id, "owner" if request.args.get("ids") == "raw" else "read")
    raw = request.args.get("ids") == "raw"
    name = (secure_filename(study.title) or f"study-{study.id}") + (
        "-participants-prolific-ids" if raw else "-participants"
    )
    return Response(
        participants_csv(study, raw_ids=raw),
        mimetype="text/csv",
        headers={
            "Content-Disposition": f'attachment; filename="{name}.csv"',
            "Cache-Control": "no-store",
        },
    )


@bp.post("/studies/<int:study_id>/participants/delete")
@login_required
def delete_participant(study_id: int):  # type: ignore[no-untyped-def]
    """Delete one participant's data on their request (the monitor and exports follow)."""

    study = own_study(study_id, "full")
    form = DeleteParticipantForm()
    if not form.validate_on_submit():
        problems = "; ".join(f"{name}: {errors[0]}" for name, errors in form.errors.items())
        flash(f"Nothing deleted ({problems}).", "error")
        return redirect(url_for(".study", study_id=study.id))
    deleted = delete_participants(study, form.participant.data or "")
    if not deleted.labels:
        flash(
            "Nothing deleted: no participant of this study has that label, Prolific ID or "
            "pseudonym.",
            "error",
        )
        return redirect(url_for(".study", study_id=study.id))
    db.session.commit()
    answers = (
        f"{deleted.ratings} ratings" if study.design in RATING_DESIGNS else f"{deleted.votes} votes"
    )
    flash(
        f"Deleted {', '.join(deleted.labels)}: {answers}, their schedule and their Prolific IDs.",
        "ok",
    )
    if study.status == "closed":  # the old report counted their votes
        _start(study, "report")
    return redirect(url_for(".study", study_id=study.id))


@bp.get("/studies/<int:study_id>/report/")
@bp.get("/studies/<int:study_id>/report/<path:name>")
@login_required
def report(study_id: int, name: str = "report.html"):  # type: ignore[no-untyped-def]

    study = own_study(study_id)
    folder = report_path(study).parent
    rel = f"{folder.name}/{name}"
    try:
        path = media_file(study, rel)
    except ValueError:
        abort(404)
    # With a bucket (MEDIA_BACKEND = "s3") this machine may hold no copy of a written report.
    in_bucket = current_app.config["MEDIA_BACKEND"] == "s3" and study.report_at is not None
    if not path.is_file() and not in_bucket:
        if name != "report.html":
            abort(404)
        return render_template("experimenter/no_report.html", study=study, action=ActionForm()), 404
    return media_response(
        study, rel, headers={"Content-Security-Policy": REPORT_CONTENT_SECURITY_POLICY}
    )


@bp.get("/studies/<int:study_id>/stimuli/<int:stimulus_id>.mp4")
@login_required
def preview(study_id: int, stimulus_id: int):  # type: ignore[no-untyped-def]
    study = own_study(study_id)
    stimulus = db.session.get(Stimulus, stimulus_id)
    if stimulus is None or stimulus.study_id != study.id or not stimulus.video_path:
        abort(404)
    return media_response(study, stimulus.video_path, mimetype="video/mp4")
