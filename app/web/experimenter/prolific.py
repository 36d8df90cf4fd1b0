"""The study's Prolific page: publish (draft, cost, confirm), sync, review (approve, reject,
request return), bonuses, top-up and the outbox (``app.web.prolific`` decides; these are its
pages). Each action writes to the outbox and sends what it can at once; what must wait (a
submission not yet awaiting review, a 429 storm) is sent by the next sync or
``facepair prolific watch``."""

from __future__ import annotations

import os
from typing import Any

from flask import current_app, flash, redirect, render_template, request, url_for

from app.errors import InputError
from app.web.experimenter.access import own_study
from app.web.experimenter.blueprint import bp
from app.web.experimenter.forms import ActionForm, ConfirmForm
from app.web.extensions import db
from app.web.infra.accounts import current_user, login_required, study_access
from app.web.models import Study
from app.web.prolific import bonus as bonuses
from app.web.prolific.client import ProlificClient, ProlificError, client_from_environment
from app.web.prolific.outbox import calls_of, drain
from app.web.prolific.outcomes import sync
from app.web.prolific.recruit import (
    account,
    draft,
    go_live,
    money,
    prolific_study,
    quote,
    recruiting_spec,
    topup_call,
    topup_proposal,
)
from app.web.prolific.review import (
    REJECTION_CATEGORIES,
    RETURN_REASONS,
    Decision,
    approve_proposed,
    decide,
    proposals,
)

#: A page waits at most this many attempts on Prolific; the rest is left to the next sync.
WEB_ATTEMPTS = 2


def _client() -> ProlificClient:
    client = client_from_environment(current_app.config)
    client.attempts, client.max_wait = min(client.attempts, WEB_ATTEMPTS), 2.0
    return client


def _who() -> str:
    user = current_user()
    return user.email if user is not None else "web"


def _back(study: Study):  # type: ignore[no-untyped-def]
    return redirect(url_for(".prolific", study_id=study.id))


def _act(study: Study, action: Any) -> None:
    """Run ``action(client)``, then send the study's outbox; one line flashed for a refusal."""
    try:
        client = _client()
        message = action(client)
        report = drain(study.id, client)
        if message:
            flash(message, "ok")
        if report.left:
            flash(f"{report.left} call(s) wait: the next sync sends them.", "info")
    except (InputError, ProlificError) as exc:
        db.session.rollback()
        flash(str(exc), "error")


@bp.get("/studies/<int:study_id>/prolific")
@login_required
def prolific(study_id: int):  # type: ignore[no-untyped-def]
    study = own_study(study_id)
    problem, spec = None, None
    try:
        spec = recruiting_spec(study)
    except InputError as exc:
        problem = str(exc)
    live, pilot = prolific_study(study), prolific_study(study, pilot=True)
    calls = calls_of(study.id)
    cost = None
    drafted = next(
        (c for c in calls if c.key == f"{study.id}:create:live" and c.state == "done"), None
    )
    published = any(c.kind == "publish" for c in calls)
    if (
        spec is not None
        and drafted is not None
        and not published
        and os.environ.get("PROLIFIC_TOKEN")
    ):
        try:
            total = quote(_client(), spec.reward, spec.places)
            cost = money(total, live.currency if live else "")
        except (InputError, ProlificError) as exc:
            cost = f"unavailable ({exc})"
    topup = None
    if live is not None and live.prolific_id:
        topup = topup_proposal(study)
    return render_template(
        "experimenter/prolific.html",
        study=study,
        spec=spec,
        problem=problem,
        token=bool(os.environ.get("PROLIFIC_TOKEN")),
        live=live,
        pilot=pilot,
        calls=calls,
        drafted=drafted,
        published=published,
        cost=cost,
        proposals=proposals(study),
        categories=REJECTION_CATEGORIES,
        return_reasons=RETURN_REASONS,
        topup=topup,
        money=money,
        runs=(study_access(study, current_user().id) or "")  # type: ignore[union-attr]
        in ("full", "owner"),
        action=ActionForm(),
        confirm=ConfirmForm(),
    )


@bp.post("/studies/<int:study_id>/prolific/draft")
@login_required
def prolific_draft(study_id: int):  # type: ignore[no-untyped-def]
    """Create the draft on Prolific (no cost yet: nothing is published)."""
    study = own_study(study_id, "full")
    if ActionForm().validate_on_submit():
        pilot = request.form.get("pilot") == "1"

        def make(client: ProlificClient) -> str:
            spec = recruiting_spec(study)
            endpoint = (
                (".pilot", {"token": study.pilot_token})
                if pilot
                else ("participant.start", {"slug": study.slug})
            )
            link = url_for(endpoint[0], _external=True, **endpoint[1])
            draft(study, spec, link, account(client, spec), pilot=pilot, who=_who())
            return "The draft is being made on Prolific."

        _act(study, make)
    return _back(study)


@bp.post("/studies/<int:study_id>/prolific/publish")
@login_required
def prolific_publish(study_id: int):  # type: ignore[no-untyped-def]
    """Publish the draft (or start Prolific's test study): only with the tick under its cost."""
    study = own_study(study_id, "full")
    form = ConfirmForm()
    if not form.validate_on_submit():
        flash("Not published: tick the box under the cost to confirm.", "error")
        return _back(study)
    pilot = request.form.get("pilot") == "1"
    create = next(
        (
            c
            for c in calls_of(study.id)
            if c.key == f"{study.id}:create:{'pilot' if pilot else 'live'}"
        ),
        None,
    )
    if create is None or create.state != "done":
        flash("Make the draft on Prolific first.", "error")
        return _back(study)
    _act(
        study,
        lambda client: (
            go_live(study, create, pilot=pilot, who=_who()) and "Publishing on Prolific."
        ),
    )
    return _back(study)


@bp.post("/studies/<int:study_id>/prolific/sync")
@login_required
def prolific_sync(study_id: int):  # type: ignore[no-untyped-def]
    study = own_study(study_id, "full")
    if ActionForm().validate_on_submit():

        def poll(client: ProlificClient) -> str:
            report = sync(study, client)
            return (
                f"{report.submissions} submission(s) read; "
                f"{report.returned} participant(s) now returned."
            )

        _act(study, poll)
    return _back(study)


@bp.post("/studies/<int:study_id>/prolific/review")
@login_required
def prolific_review(study_id: int):  # type: ignore[no-untyped-def]
    """Approve the ticked (or every proposed) submission, or reject or request the return of
    one, with the category and message typed on the page."""
    study = own_study(study_id, "full")
    if not ActionForm().validate_on_submit():
        return _back(study)
    what = request.form.get("do", "")

    def carry_out(client: ProlificClient) -> str:
        if what == "approve-all":
            written = approve_proposed(study, who=_who())
        elif what == "approve":
            chosen = request.form.getlist("submission")
            if not chosen:
                raise InputError("tick the submissions to approve", field="submission")
            written = decide(study, [Decision(s, "approve") for s in chosen], who=_who())
        elif what == "reject":
            decision = Decision(
                request.form.get("submission", ""),
                "reject",
                request.form.get("category", ""),
                request.form.get("message", ""),
            )
            written = decide(study, [decision], who=_who())
        elif what == "return":
            reason = request.form.get("reason", "")
            written = decide(
                study,
                [Decision(request.form.get("submission", ""), "return", reasons=(reason,))],
                who=_who(),
            )
        else:
            raise InputError("unknown review action", field="do")
        return f"{len(written)} decision(s) written to the outbox."

    _act(study, carry_out)
    return _back(study)


@bp.post("/studies/<int:study_id>/prolific/bonus")
@login_required
def prolific_bonus(study_id: int):  # type: ignore[no-untyped-def]
    """Set up the pasted bonuses as batches; with the tick, pay the batches set up (each once)."""
    study = own_study(study_id, "full")
    if not ActionForm().validate_on_submit():
        return _back(study)
    paying = request.form.get("confirm") == "y"

    def bonus(client: ProlificClient) -> str:
        amounts = bonuses.parse_bonus_csv(request.form.get("csv", ""), source="bonuses")
        found = bonuses.batches(study, amounts, who=_who())
        drain(study.id, client)
        lines = []
        for batch in found:
            db.session.refresh(batch.setup)
            if batch.pay is not None:
                lines.append(
                    f"batch {batch.setup.result_id}: already paid (call #{batch.pay.id}); "
                    "nothing paid"
                )
            elif batch.setup.state != "done":
                lines.append(f"batch not set up yet: {batch.setup.note or batch.setup.state}")
            elif paying:
                bonuses.pay(study, batch, who=_who())
                lines.append(f"batch {batch.setup.result_id}: paying {batch.total:.2f}")
            else:
                total = (batch.setup.result or {}).get("total_amount", 0)
                currency = prolific_study(study).currency  # type: ignore[union-attr]
                lines.append(
                    f"batch {batch.setup.result_id}: {len(batch.bonuses)} bonus(es), "
                    f"{batch.total:.2f} {currency}, {money(total, currency)} with fees and VAT; "
                    "tick the box to pay it"
                )
        return " ".join(lines)

    _act(study, bonus)
    return _back(study)


@bp.post("/studies/<int:study_id>/prolific/topup")
@login_required
def prolific_topup(study_id: int):  # type: ignore[no-untyped-def]
    study = own_study(study_id, "full")
    if not ConfirmForm().validate_on_submit():
        flash("Places not raised: tick the box to confirm.", "error")
        return _back(study)
    try:
        places = int(request.form.get("places", ""))
    except ValueError:
        flash("places: expected a number.", "error")
        return _back(study)
    _act(
        study,
        lambda client: topup_call(study, places, who=_who()) and f"Raising the places to {places}.",
    )
    return _back(study)
