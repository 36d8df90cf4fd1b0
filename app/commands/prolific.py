"""``facepair prolific ...``: recruiting on Prolific from the shell, with the same services as
the study's Prolific page (``app.web.prolific``; ``docs/reference/prolific.md``).

Every change at Prolific goes through the outbox: it is written, then sent, then marked done,
so running a command again (after a crash, a timeout, by mistake) never sends a call twice.
A refusal or an unreachable Prolific is one line (exit code 1); bad input is one line (exit
code 2).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

import click

from app.commands.db import migrated
from app.commands.studies import _study
from app.commands.webapp import app_context, offline_app
from app.errors import InputError


class ProlificGroup(click.Group):
    """Turns Prolific's refusals and outages into one line and exit code 1."""

    def invoke(self, ctx: click.Context):  # type: ignore[override]
        from app.web.prolific.client import ProlificError

        try:
            return super().invoke(ctx)
        except ProlificError as exc:
            click.echo(f"facepair: error: {exc}", err=True)
            sys.exit(1)


@click.group(cls=ProlificGroup)
def prolific() -> None:
    """Publish on Prolific, follow submissions, review, pay bonuses, top up places."""


def _client():  # type: ignore[no-untyped-def]
    from flask import current_app

    from app.web.prolific.client import client_from_environment

    return client_from_environment(current_app.config)


def _drain(study_id: int, client: Any) -> None:
    from app.web.prolific.outbox import drain

    report = drain(study_id, client)
    if report.reconciled:
        click.echo(f"{report.reconciled} call(s) left by an earlier run reconciled with Prolific")
    if report.left:
        click.echo(f"{report.left} call(s) waiting (see 'facepair prolific status {study_id}')")


def _fail(line: str) -> None:
    click.echo(f"facepair: error: {line}", err=True)
    sys.exit(1)


def _call_line(call: Any) -> str:
    return f"call #{call.id} {call.kind} {call.state}" + (f": {call.note}" if call.note else "")


def _links(app: Any, study: Any, base_url: str, *, pilot: bool) -> str:
    from flask import url_for

    with app.test_request_context(base_url=base_url.rstrip("/")):
        if pilot:
            return url_for("experimenter.pilot", token=study.pilot_token, _external=True)
        return url_for("participant.start", slug=study.slug, _external=True)


@prolific.command("publish")
@click.argument("study_id", type=int)
@click.option(
    "--pilot",
    is_flag=True,
    help="Prolific's test study (test participants only), from a draft on the pilot link.",
)
@click.option("--yes", is_flag=True, help="Publish without asking (for scripts).")
@click.option(
    "--base-url",
    envvar="FACEPAIR_PUBLIC_URL",
    default=None,
    help="facepair's public address (default $FACEPAIR_PUBLIC_URL): the participant link's base.",
)
@click.option(
    "--prolific-file",
    type=click.Path(dir_okay=False, exists=True, path_type=Path),
    default=None,
    help="A TOML file with the [prolific] table, for a study whose file has none.",
)
def publish(
    study_id: int, pilot: bool, yes: bool, base_url: str | None, prolific_file: Path | None
) -> None:
    """Create STUDY_ID's Prolific study as a draft, show its cost, ask, then publish it."""
    import sqlalchemy as sa

    from app.web.prolific.models import ProlificCall
    from app.web.prolific.recruit import account, draft, go_live, money, quote, recruiting_spec

    if not base_url:
        raise InputError(
            "give facepair's public address (Prolific sends participants there)", field="base-url"
        )
    app = offline_app()
    with app_context(app):
        migrated()
        study = _study(study_id)
        text = prolific_file.read_text(encoding="utf-8") if prolific_file else None
        spec = recruiting_spec(study, text, source=str(prolific_file or "study file"))
        client = _client()
        acct = account(client, spec)
        link, create = draft(
            study, spec, _links(app, study, base_url, pilot=pilot), acct, pilot=pilot, who="cli"
        )
        _drain(study.id, client)
        from app.web.extensions import db

        db.session.refresh(create)
        if create.state != "done":
            _fail(f"the draft is not made yet: {_call_line(create)}")
        click.echo(f"Prolific draft {create.result_id} for study {study.id} ({_call_line(create)})")
        total = quote(client, spec.reward, spec.places)
        rewards = spec.reward * spec.places
        click.echo(
            f"cost: {spec.places} places x {money(spec.reward, acct.currency)} = "
            f"{money(rewards, acct.currency)} in rewards; {money(total, acct.currency)} with "
            f"Prolific's fees and VAT (workspace {acct.workspace_id}: "
            f"{money(acct.available, acct.currency)} available)"
        )
        kind = "test_study" if pilot else "publish"
        earlier = db.session.scalar(
            sa.select(ProlificCall).where(ProlificCall.key == f"{study.id}:{kind}")
        )
        if earlier is not None and earlier.state == "done":
            click.echo(f"already done: {_call_line(earlier)}")
            return
        what = "Start Prolific's test study" if pilot else "Publish it"
        if earlier is None and not yes and not click.confirm(f"{what}?", default=False):
            click.echo(
                "not published: the draft waits on Prolific; run this command again to publish"
            )
            return
        live = go_live(study, create, pilot=pilot, who="cli")
        _drain(study.id, client)
        db.session.refresh(live)
        click.echo(_call_line(live))


@prolific.command("status")
@click.argument("study_id", type=int)
def status(study_id: int) -> None:
    """STUDY_ID's Prolific study and its outbox: every call, its state and Prolific's answer."""
    import sqlalchemy as sa

    from app.web.extensions import db
    from app.web.prolific.models import ProlificStudy
    from app.web.prolific.outbox import calls_of
    from app.web.prolific.recruit import money

    with app_context(offline_app()):
        migrated()
        study = _study(study_id)
        links = db.session.scalars(
            sa.select(ProlificStudy).where(ProlificStudy.study_id == study.id)
        ).all()
        if not links:
            click.echo(f"study {study.id} is not on Prolific")
        for link in links:
            click.echo(
                f"{'pilot' if link.pilot else 'study'}: {link.prolific_id or '(no draft yet)'} "
                f"{link.status or '-'}, {link.places} places, reward "
                f"{money(link.reward, link.currency)}"
                + (f", test study {link.test_study_id}" if link.test_study_id else "")
            )
        rows = calls_of(study.id)
        if rows:
            click.echo(f"{'id':>5}  {'kind':<10} {'target':<26} {'state':<9} tries  note")
        for row in rows:
            click.echo(
                f"{row.id:>5}  {row.kind:<10} {row.target or '-':<26} {row.state:<9} "
                f"{row.attempts:>5}  {row.note}"
            )


@prolific.command("sync")
@click.argument("study_id", type=int, required=False)
@click.option("--all", "every", is_flag=True, help="Every study on Prolific.")
def sync_command(study_id: int | None, every: bool) -> None:
    """Poll Prolific for STUDY_ID's submissions (a RETURNED or TIMED-OUT one makes its
    participant returned) and send the calls waiting in its outbox."""
    if (study_id is None) == (not every):
        raise InputError("give a STUDY_ID or --all", field="STUDY_ID")
    with app_context(offline_app()):
        migrated()
        failed = _sync_round([study_id] if study_id is not None else None, _client())
    if failed:
        sys.exit(1)


def _sync_round(study_ids: list[int] | None, client: Any) -> int:
    import sqlalchemy as sa

    from app.web.extensions import db
    from app.web.prolific.client import ProlificError
    from app.web.prolific.models import ProlificCall, ProlificStudy
    from app.web.prolific.outcomes import sync

    if study_ids is None:
        # every study on Prolific, and every study with calls still to send (a draft whose
        # create call found Prolific away has no Prolific id yet)
        on_prolific = sa.select(ProlificStudy.study_id).where(
            ProlificStudy.prolific_id.is_not(None)
        )
        waiting = sa.select(ProlificCall.study_id).where(
            ProlificCall.state.in_(("pending", "sending", "doubt"))
        )
        study_ids = sorted(set(db.session.scalars(on_prolific)) | set(db.session.scalars(waiting)))
    failed = 0
    for study_id in study_ids:
        study = _study(study_id)
        try:
            report = sync(study, client)
            click.echo(
                f"study {study.id}: {report.submissions} submission(s) read, "
                f"{report.returned} participant(s) now returned"
            )
            _drain(study.id, client)
        except ProlificError as exc:
            db.session.rollback()
            click.echo(f"study {study.id}: {exc}", err=True)
            failed += 1
    return failed


@prolific.command("watch")
@click.option(
    "--every",
    default=300,
    show_default=True,
    type=click.IntRange(10),
    help="Seconds between rounds.",
)
@click.option(
    "--rounds", default=0, type=click.IntRange(0), help="Stop after this many rounds (0: never)."
)
def watch(every: int, rounds: int) -> None:
    """The periodic job: sync every study on Prolific and send what its outbox holds, every
    --every seconds (for deployments without a public webhook URL; cron may run
    'sync --all' instead)."""
    done = 0
    with app_context(offline_app()):
        migrated()
        client = _client()
        while True:
            _sync_round(None, client)
            done += 1
            if rounds and done >= rounds:
                return
            time.sleep(every)


@prolific.command("review")
@click.argument("study_id", type=int)
@click.option(
    "--approve-all", is_flag=True, help="Approve every submission proposed for approval (in bulk)."
)
@click.option(
    "--approve",
    "approve",
    multiple=True,
    help="Approve this participant (P0007, Prolific ID or submission).",
)
@click.option(
    "--reject",
    "reject",
    multiple=True,
    help="Reject this participant (each named; asks unless --yes).",
)
@click.option(
    "--category", default=None, help="Prolific's rejection category (default: the proposal's)."
)
@click.option(
    "--message",
    default=None,
    help="The rejection message, 100 characters or more (default: the proposal's).",
)
@click.option(
    "--return", "give_back", multiple=True, help="Ask this participant to return the submission."
)
@click.option(
    "--reason", default=None, help="The return request's reason (default: the proposal's)."
)
@click.option("--yes", is_flag=True, help="Do not ask before rejecting or requesting returns.")
def review(
    study_id: int,
    approve_all: bool,
    approve: tuple[str, ...],
    reject: tuple[str, ...],
    category: str | None,
    message: str | None,
    give_back: tuple[str, ...],
    reason: str | None,
    yes: bool,
) -> None:
    """Sync STUDY_ID, list a proposal per submission from facepair's verdicts, and carry out
    the decisions given (nothing is rejected unless named here)."""
    from app.web.prolific.outcomes import sync
    from app.web.prolific.review import (
        Decision,
        approve_proposed,
        decide,
        find_submission,
        proposals,
    )

    with app_context(offline_app()):
        migrated()
        study = _study(study_id)
        client = _client()
        sync(study, client)
        by_id = {p.submission_id: p for p in proposals(study)}
        for p in by_id.values():
            decided = ", ".join(f"{c.kind} #{c.id} {c.state}" for c in p.decided) or "-"
            click.echo(
                f"{p.label or '-':<6} {p.prolific_pid:<24} {p.status:<16} {p.facepair_status:<13} "
                f"{p.action:<8} {p.reason}  [{decided}]"
            )
        decisions: list[Decision] = [
            Decision(find_submission(study, who), "approve") for who in approve
        ]
        for who in reject:
            sid = find_submission(study, who)
            proposal = by_id[sid]
            chosen = Decision(
                sid, "reject", category or proposal.category, message or proposal.message
            )
            if not yes and not click.confirm(
                f"Reject {proposal.label or proposal.prolific_pid} ({chosen.category}): "
                f"{chosen.message!r}?",
                default=False,
            ):
                continue
            decisions.append(chosen)
        for who in give_back:
            sid = find_submission(study, who)
            proposal = by_id[sid]
            why = reason or proposal.return_reason or "Didn't finish the study"
            if not yes and not click.confirm(
                f"Ask {proposal.label or proposal.prolific_pid} to return ({why})?", default=False
            ):
                continue
            decisions.append(Decision(sid, "return", reasons=(why,)))
        written = decide(study, decisions, who="cli") if decisions else []
        if approve_all:
            written += approve_proposed(study, who="cli")
        _drain(study.id, client)
        from app.web.extensions import db

        for row, _new in written:
            db.session.refresh(row)
            click.echo(_call_line(row))


@prolific.command("bonus")
@click.argument("study_id", type=int)
@click.option(
    "--csv",
    "csv_file",
    type=click.Path(dir_okay=False, exists=True, path_type=Path),
    help="Lines of Prolific ID,amount (in the study's currency, e.g. 1.50).",
)
@click.option(
    "--rule",
    is_flag=True,
    help="The study file's bonus_per_check for each correct attention check.",
)
@click.option("--yes", is_flag=True, help="Pay without asking (for scripts).")
def bonus(study_id: int, csv_file: Path | None, rule: bool, yes: bool) -> None:
    """Set up STUDY_ID's bonuses as Prolific batches, show their cost, ask, and pay each batch
    once: the same file again pays nothing."""
    from app.web.extensions import db
    from app.web.prolific.bonus import batches, earlier, parse_bonus_csv, pay, rule_bonuses
    from app.web.prolific.recruit import money, prolific_study, recruiting_spec

    if (csv_file is None) == (not rule):
        raise InputError("give --csv FILE or --rule", field="csv")
    with app_context(offline_app()):
        migrated()
        study = _study(study_id)
        if csv_file is not None:
            amounts = parse_bonus_csv(csv_file.read_text(encoding="utf-8"), source=str(csv_file))
        else:
            per_check = recruiting_spec(study).bonus_per_check
            if per_check is None:
                raise InputError("the [prolific] table has no bonus_per_check", field="rule")
            amounts = rule_bonuses(study, per_check)
            if not amounts:
                click.echo("the rule gives nobody a bonus")
                return
        client = _client()
        link = prolific_study(study)
        currency = link.currency if link else ""
        found = batches(study, amounts, who="cli")
        for pid, lines in earlier(study, amounts, {b.setup.id for b in found}).items():
            click.echo(f"note: {pid} already had bonuses set up: {'; '.join(lines)}")
        _drain(study.id, client)
        for batch in found:
            db.session.refresh(batch.setup)
            if batch.pay is not None and batch.pay.state in ("done", "sending", "doubt"):
                click.echo(
                    f"batch {batch.setup.result_id or '#' + str(batch.setup.id)}: its payment "
                    f"was made before ({_call_line(batch.pay)}); nothing paid now"
                )
                continue
            if batch.setup.state != "done":
                click.echo(f"batch not set up: {_call_line(batch.setup)}")
                continue
            result = batch.setup.result or {}
            click.echo(
                f"batch {batch.setup.result_id}: {len(batch.bonuses)} bonus(es), "
                f"{batch.total:.2f} {currency}; {money(result.get('total_amount', 0), currency)} "
                "with Prolific's fees and VAT"
            )
            if batch.pay is None:
                if not yes and not click.confirm("Pay it?", default=False):
                    click.echo("not paid: run this command again to pay it")
                    continue
                pay(study, batch, who="cli")
        _drain(study.id, client)
        for batch in found:
            if batch.pay is not None:
                db.session.refresh(batch.pay)
                click.echo(_call_line(batch.pay))


@prolific.command("topup")
@click.argument("study_id", type=int)
@click.option(
    "--places", type=click.IntRange(1), default=None, help="Raise the places to this many."
)
@click.option(
    "--target",
    type=click.IntRange(1),
    default=None,
    help="Participants needed (e.g. from 'facepair plan'); default: target_participants.",
)
@click.option("--yes", is_flag=True, help="Raise without asking.")
def topup(study_id: int, places: int | None, target: int | None, yes: bool) -> None:
    """Raise STUDY_ID's places on Prolific when the participants counted fall short."""
    from app.web.prolific.outcomes import sync
    from app.web.prolific.recruit import topup_call, topup_proposal

    with app_context(offline_app()):
        migrated()
        study = _study(study_id)
        client = _client()
        sync(study, client)
        _drain(study.id, client)  # an earlier run's raise is finished first
        plan = topup_proposal(study, target=target)
        click.echo(
            f"{plan.counted} counted of {plan.target} needed; {plan.in_flight} under way, "
            f"{plan.free} free place(s) Prolific refills; {plan.current} places"
        )
        wanted = places or plan.proposed
        if wanted <= plan.current:
            click.echo("no more places needed")
            return
        if not yes and not click.confirm(
            f"Raise the places from {plan.current} to {wanted}?", default=False
        ):
            return
        call, _ = topup_call(study, wanted, who="cli")
        _drain(study.id, client)
        from app.web.extensions import db

        db.session.refresh(call)
        click.echo(_call_line(call))


@prolific.command("resolve")
@click.argument("call_id", type=int)
@click.option(
    "--sent", "how", flag_value="sent", help="It was sent (Prolific's page shows it): mark it done."
)
@click.option("--not-sent", "how", flag_value="not-sent", help="It was not sent: send it again.")
@click.option("--cancel", "how", flag_value="cancel", help="Drop it unsent.")
def resolve_command(call_id: int, how: str | None) -> None:
    """A person's decision on call CALL_ID (one in doubt, or one to cancel)."""
    from app.web.extensions import db
    from app.web.prolific.models import ProlificCall
    from app.web.prolific.outbox import resolve

    if how is None:
        raise InputError("give --sent, --not-sent or --cancel", field="resolution")
    with app_context(offline_app()):
        migrated()
        row = db.session.get(ProlificCall, call_id)
        if row is None:
            raise InputError(f"no call {call_id}", field="CALL_ID")
        state = resolve(row, how, who="cli")
        click.echo(f"call #{call_id} is {state}")
        if state == "pending":
            _drain(row.study_id, _client())


@prolific.command("hooks")
@click.argument("url")
@click.option(
    "--workspace",
    default=None,
    help="Prolific workspace id (default: $PROLIFIC_WORKSPACE_ID or the only one).",
)
@click.option(
    "--new-secret", is_flag=True, help="Replace the workspace's webhook secret and print it once."
)
def hooks(url: str, workspace: str | None, new_secret: bool) -> None:
    """Subscribe URL (facepair's /api/v1/prolific/webhook, https) to submission and study
    status changes."""
    from app.web.prolific.hooks import subscribe, workspace_id

    with app_context(offline_app()):
        client = _client()
        secret, lines = subscribe(
            client, workspace_id(client, workspace), url, new_secret=new_secret
        )
    for line in lines:
        click.echo(line)
    if secret:
        click.echo(
            "the workspace's new webhook secret (shown once, kept nowhere): set it as "
            f"PROLIFIC_WEBHOOK_SECRET in the web process's environment:\n{secret}"
        )


def register(main: click.Group) -> None:
    main.add_command(prolific)
