"""A study's life beyond draft -> open -> closed: the pilot link, reopening, copies, deletion
and collaborators (``app.web.study.studies`` holds the rules, these are their pages)."""

from __future__ import annotations

import sqlalchemy as sa
from flask import abort, flash, redirect, render_template, url_for

from app.web.experimenter.access import own_study
from app.web.experimenter.blueprint import bp
from app.web.experimenter.forms import (
    ActionForm,
    ConfirmForm,
    DeleteStudyForm,
    DuplicateForm,
    PilotConsentForm,
    ShareForm,
)
from app.web.extensions import db
from app.web.infra.accounts import current_user, login_required
from app.web.infra.limits import fits
from app.web.models import Stimulus, Study, StudyShare, User
from app.web.study.enrolment import enrol
from app.web.study.studies import change_status, delete_study, duplicate_study


@bp.route("/pilot/<token>", methods=["GET", "POST"])
def pilot(token: str):  # type: ignore[no-untyped-def]
    """The pilot link: the study's consent page, as participants will see it; agreeing enrols
    a pilot participant before (or during) recruitment.

    Anyone with the link may pilot, so it can go to colleagues without an account; the
    participant is flagged, so their votes stay out of exports and the analysis unless asked
    for, and their list slot goes back when recruitment opens.
    """

    study = None
    if fits(Study.pilot_token, token):
        study = db.session.scalar(sa.select(Study).where(Study.pilot_token == token))
    if study is None:
        abort(404)
    unrendered = db.session.scalar(
        sa.select(sa.func.count(Stimulus.id)).where(
            Stimulus.study_id == study.id, Stimulus.video_path.is_(None)
        )
    )
    if study.status == "closed" or unrendered:
        why = "closed" if study.status == "closed" else "not rendered yet"
        return render_template(
            "participant/unavailable.html",
            study=study,
            reason=f"this pilot cannot run: the study is {why}",
        ), 503
    form = PilotConsentForm()
    if not form.validate_on_submit():
        action = url_for(".pilot", token=token)
        return render_template("participant/consent.html", study=study, form=form, action=action)
    participant = enrol(study, user_agent="pilot")
    participant.pilot = True
    db.session.commit()
    # where a participant goes after consenting: a questionnaire page first, if any
    return redirect(url_for("participant.resume", token=participant.token))


@bp.post("/studies/<int:study_id>/reopen")
@login_required
def reopen(study_id: int):  # type: ignore[no-untyped-def]
    """Open a closed study again: only with the tick (its report becomes provisional)."""

    study = own_study(study_id, "full")
    if not ConfirmForm().validate_on_submit():
        flash("Not reopened: tick the box to confirm.", "error")
        return redirect(url_for(".study", study_id=study.id))
    try:
        change_status(study, "reopen")
    except ValueError as exc:
        flash(str(exc), "error")
        return redirect(url_for(".study", study_id=study.id))
    db.session.commit()
    flash("Recruitment is open again; the report is rewritten when the study closes.", "ok")
    return redirect(url_for(".study", study_id=study.id))


@bp.post("/studies/<int:study_id>/duplicate")
@login_required
def duplicate(study_id: int):  # type: ignore[no-untyped-def]

    study = own_study(study_id, "full")
    form = DuplicateForm()
    if not form.validate_on_submit():
        abort(400)
    copy = duplicate_study(study, current_user(), with_clips=bool(form.with_clips.data))  # type: ignore[arg-type]
    db.session.commit()
    flash(f"Copied as {copy.title!r} ({copy.status}).", "ok")
    return redirect(url_for(".study", study_id=copy.id))


@bp.post("/studies/<int:study_id>/delete")
@login_required
def delete(study_id: int):  # type: ignore[no-untyped-def]

    study = own_study(study_id, "owner")
    form = DeleteStudyForm()
    if not form.validate_on_submit() or (form.title.data or "").strip() != study.title.strip():
        flash("Nothing deleted: type the study's title exactly to confirm.", "error")
        return redirect(url_for(".study", study_id=study.id))
    title = study.title
    delete_study(study)
    db.session.commit()
    flash(f"Deleted {title!r} with its participants, votes and files.", "ok")
    return redirect(url_for(".studies"))


@bp.post("/studies/<int:study_id>/shares")
@login_required
def share(study_id: int):  # type: ignore[no-untyped-def]
    study = own_study(study_id, "owner")
    form = ShareForm()
    if not form.validate_on_submit():
        problems = "; ".join(f"{name}: {errors[0]}" for name, errors in form.errors.items())
        flash(f"Not shared ({problems}).", "error")
        return redirect(url_for(".study", study_id=study.id))
    email = (form.email.data or "").strip().lower()
    user = db.session.scalar(sa.select(User).where(User.email == email))
    if user is None or user.id == study.owner_id:
        flash(f"Not shared: no other experimenter has the account {email!r}.", "error")
        return redirect(url_for(".study", study_id=study.id))
    existing = db.session.scalar(
        sa.select(StudyShare).where(StudyShare.study_id == study.id, StudyShare.user_id == user.id)
    )
    if existing is None:
        db.session.add(StudyShare(study_id=study.id, user_id=user.id, access=form.access.data))
    else:
        existing.access = form.access.data or "read"
    db.session.commit()
    flash(f"Shared with {email} ({form.access.data}).", "ok")
    return redirect(url_for(".study", study_id=study.id))


@bp.post("/studies/<int:study_id>/shares/<int:share_id>/remove")
@login_required
def unshare(study_id: int, share_id: int):  # type: ignore[no-untyped-def]
    study = own_study(study_id, "owner")
    row = db.session.get(StudyShare, share_id)
    if row is None or row.study_id != study.id or not ActionForm().validate_on_submit():
        abort(404)
    db.session.delete(row)
    db.session.commit()
    return redirect(url_for(".study", study_id=study.id))


def shares_of(study: Study) -> list[StudyShare]:
    return list(
        db.session.scalars(
            sa.select(StudyShare).where(StudyShare.study_id == study.id).order_by(StudyShare.id)
        )
    )
