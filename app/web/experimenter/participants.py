"""The monitor's participant table, excluding a participant by hand and undoing it, and the
downloads beyond the votes: questionnaire answers and the study package."""

from __future__ import annotations

from typing import Any

import sqlalchemy as sa
from flask import Response, flash, redirect, request, url_for
from werkzeug.utils import secure_filename

from app.errors import InputError
from app.trials.participation import PARTICIPANT_STATUSES, SCREENED_OUT_REASON
from app.web.experimenter.access import own_study
from app.web.experimenter.blueprint import bp
from app.web.experimenter.forms import ExcludeForm, RestoreForm
from app.web.extensions import db
from app.web.infra.accounts import current_user, login_required, study_access
from app.web.models import Participant, Study, utcnow
from app.web.study.enrolment import dropped_after
from app.web.study.labels import pseudonym
from app.web.study.package import build_package, package_name
from app.web.study.participants import (
    AUTO_RULES,
    auto_rules,
    participant_table,
    remove,
    restore,
)
from app.web.study.questionnaires import answers_csv


def monitor_table(study: Study) -> dict[str, Any]:
    """What the monitor's table needs: the rows, Prolific IDs as shown (pseudonyms unless the
    experimenter asked to reveal them and may), and the exclusion form."""

    access = study_access(study, current_user().id)  # type: ignore[union-attr]
    may_reveal = access in ("full", "owner")
    reveal = may_reveal and request.args.get("reveal") == "1"
    rows = participant_table(study, dropped_after=dropped_after())
    shown = {
        row.id: (row.prolific_pid if reveal else pseudonym(study.pseudonym_key, row.prolific_pid))
        for row in rows
    }
    return {
        "participants": rows,
        "prolific_shown": shown,
        "reveal": reveal,
        "may_reveal": may_reveal,
        "exclude_form": ExcludeForm(),
        "auto_rules": [AUTO_RULES[rule] for rule in auto_rules(study)],
        "status_meanings": PARTICIPANT_STATUSES,
        "screened_out_reason": SCREENED_OUT_REASON,
        "now": utcnow(),
    }


def _labelled(study: Study, label: str) -> Participant | None:
    """The participant of ``study`` with the export label ``label`` (``P0007``, ``p7``)."""
    number = label.strip().upper().removeprefix("P")
    if not (number.isascii() and number.isdigit() and len(number) <= 12):
        return None
    return db.session.scalar(
        sa.select(Participant).where(
            Participant.study_id == study.id, Participant.number == int(number)
        )
    )


@bp.post("/studies/<int:study_id>/participants/exclude")
@login_required
def exclude_participant(study_id: int):  # type: ignore[no-untyped-def]
    """Exclude a participant with a reason, or record a returned submission; their list slot
    goes back to the list (``app.web.study.participants.remove``)."""

    study = own_study(study_id, "full")
    form = ExcludeForm()
    back = redirect(url_for(".monitor", study_id=study.id))
    if not form.validate_on_submit():
        problems = "; ".join(f"{name}: {errors[0]}" for name, errors in form.errors.items())
        flash(f"Nobody excluded ({problems}).", "error")
        return back
    person = _labelled(study, form.participant.data or "")
    if person is None:
        flash("Nobody excluded: no participant of this study has that label.", "error")
        return back
    if person.excluded_at is not None:
        flash(f"{form.participant.data} is already {person.exclusion_kind}.", "error")
        return back
    try:
        remove(person, how=form.how.data or "", reason=form.reason.data or "")
    except ValueError as exc:
        flash(f"Nobody excluded: {exc}.", "error")
        return back
    db.session.commit()
    flash(f"P{person.number:04d} {form.how.data}; their list slot is free again.", "ok")
    return back


@bp.post("/studies/<int:study_id>/participants/restore")
@login_required
def restore_participant(study_id: int):  # type: ignore[no-untyped-def]
    """Undo an exclusion or a recorded return (``app.web.study.participants.restore``)."""

    study = own_study(study_id, "full")
    form = RestoreForm()
    back = redirect(url_for(".monitor", study_id=study.id))
    person = _labelled(study, form.participant.data or "") if form.validate_on_submit() else None
    if person is None or person.excluded_at is None:
        flash("Nothing undone: no excluded participant of this study has that label.", "error")
        return back
    restore(person)
    db.session.commit()
    flash(f"P{person.number:04d} counts again.", "ok")
    return back


@bp.get("/studies/<int:study_id>/answers.csv")
@login_required
def export_answers(study_id: int):  # type: ignore[no-untyped-def]
    """The questionnaire answers, one row per participant (joined to the votes by label)."""

    study = own_study(study_id)
    pilot = request.args.get("pilot") == "only"
    name = (secure_filename(study.title) or f"study-{study.id}") + (
        "-pilot-answers" if pilot else "-answers"
    )
    return Response(
        answers_csv(study, pilot=pilot),
        mimetype="text/csv",
        headers={
            "Content-Disposition": f'attachment; filename="{name}.csv"',
            "Cache-Control": "no-store",
        },
    )


@bp.get("/studies/<int:study_id>/package.zip")
@login_required
def export_package(study_id: int):  # type: ignore[no-untyped-def]
    """The study package (``app.web.study.package``): one zip for a paper's supplement."""

    study = own_study(study_id)
    try:
        data = build_package(study)
    except InputError as exc:
        flash(f"No package: {exc.message}.", "error")
        return redirect(url_for(".study", study_id=study.id))
    return Response(
        data,
        mimetype="application/zip",
        headers={
            "Content-Disposition": f'attachment; filename="{package_name(study)}"',
            "Cache-Control": "no-store",
        },
    )
