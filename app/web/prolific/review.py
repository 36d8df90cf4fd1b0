"""Reviewing submissions: a proposal per submission from facepair's own verdicts, and the
decisions a person confirms, written to the outbox.

The proposal follows what facepair knows of the participant (``app.web.study.participants``):
finished and counted -> approve; screened out by the attention rule, or a failed catch trial
under the ``catch_failed`` rule -> reject (``FAILED_CHECK``); a submission with no facepair data
-> reject (``NO_DATA``); a failed audio check or an unfinished session -> request a return
(neither is the participant's fault for sure); excluded by hand -> the experimenter decides.
Nothing is rejected or returned by a proposal alone: :func:`decide` takes each decision from a
person (the review page's form, or ``facepair prolific review --reject ...``). Approvals wait
until Prolific has the submission awaiting review (``calls.approve_in_bulk``).

Prolific's rules, from its OpenAPI document: a rejection needs a ``rejection_category`` from
:data:`REJECTION_CATEGORIES` and a message of at least :data:`MIN_MESSAGE` characters; a return
request needs at least one reason (free text; Prolific's own page offers
:data:`RETURN_REASONS`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import sqlalchemy as sa

from app.errors import InputError
from app.web.extensions import db
from app.web.models import Study
from app.web.prolific.calls import FINAL, NOT_YET
from app.web.prolific.models import ProlificCall, ProlificSubmission
from app.web.prolific.outbox import Intent, record
from app.web.prolific.outcomes import participant_for
from app.web.study.enrolment import dropped_after
from app.web.study.participants import AUTO_RULES, ParticipantRow, participant_table

REJECTION_CATEGORIES = (
    "TOO_QUICKLY",
    "TOO_SLOWLY",
    "FAILED_INSTRUCTIONS",
    "INCOMP_LONGITUDINAL",
    "FAILED_CHECK",
    "LOW_EFFORT",
    "MALINGERING",
    "NO_CODE",
    "BAD_CODE",
    "NO_DATA",
    "UNSUPP_DEVICE",
    "OTHER",
)
MIN_MESSAGE = 100
RETURN_REASONS = ("Didn't finish the study", "Encountered technical problems", "Withdrew consent")
ACTIONS = ("approve", "reject", "return")

FAILED_CHECK = (
    "Thank you for taking part. Your submission answered {failed} of the study's {total} "
    "attention checks other than the instructions asked, so we cannot use its answers and "
    "have to reject it."
)
SCREENED_OUT = (
    "Thank you for taking part. The study ended your session after failed attention checks "
    "(answers other than the instructions asked), so we cannot use its answers and have to "
    "reject it."
)
NO_DATA = (
    "We received nothing from this submission in our study software: no consent and no "
    "answers are recorded under your session, so there is no data we could approve."
)


@dataclass
class Proposal:
    """What facepair proposes for one submission, and what has been decided already."""

    submission_id: str
    prolific_pid: str
    status: str
    label: str
    facepair_status: str
    action: str
    reason: str
    category: str = ""
    message: str = ""
    return_reason: str = ""
    decided: list[ProlificCall] = field(default_factory=list)

    @property
    def open(self) -> bool:
        """Whether a decision can still be made (nothing decided, Prolific not final)."""
        return self.status not in FINAL and not any(
            c.state not in ("cancelled", "failed") for c in self.decided
        )


def _propose(row: ParticipantRow | None, status: str) -> tuple[str, str, str, str, str]:
    """(action, reason, category, message, return reason) for one submission."""
    if status in FINAL:
        return "none", f"Prolific: {status}", "", "", ""
    if row is None:
        if status in NOT_YET:
            return "none", "taking part (not in facepair yet)", "", "", ""
        return "reject", "no data in facepair under this submission", "NO_DATA", NO_DATA, ""
    if row.pilot:
        return "none", "pilot participant", "", "", ""
    if row.status == "returned":
        return "none", "returned", "", "", ""
    if row.status == "excluded":
        return "decide", f"excluded by hand: {row.reason}", "", "", ""
    if row.status == "screened_out":
        return "reject", "screened out by the attention rule", "FAILED_CHECK", SCREENED_OUT, ""
    if row.status != "finished":
        if status in NOT_YET:
            return "none", "taking part", "", "", ""
        return "return", "did not finish", "", "", RETURN_REASONS[0]
    if row.excluded.startswith(AUTO_RULES["catch_failed"]):
        message = FAILED_CHECK.format(
            failed=row.catch_total - row.catch_passed, total=row.catch_total
        )
        return "reject", row.excluded, "FAILED_CHECK", message, ""
    if row.audio_check == "failed":
        return "return", "failed the audio check", "", "", RETURN_REASONS[1]
    waits = " (waits until Prolific has it awaiting review)" if status in NOT_YET else ""
    return "approve", f"finished and counted{waits}", "", "", ""


def proposals(study: Study) -> list[Proposal]:
    """A proposal for each of ``study``'s Prolific submissions (as last synced)."""
    rows = {r.id: r for r in participant_table(study, dropped_after=dropped_after())}
    decided: dict[str, list[ProlificCall]] = {}
    for call in db.session.scalars(
        sa.select(ProlificCall)
        .where(ProlificCall.study_id == study.id, ProlificCall.kind.in_(ACTIONS))
        .order_by(ProlificCall.id)
    ):
        decided.setdefault(call.target, []).append(call)
    out = []
    for sub in db.session.scalars(
        sa.select(ProlificSubmission)
        .where(ProlificSubmission.study_id == study.id)
        .order_by(ProlificSubmission.started_at, ProlificSubmission.id)
    ):
        person = participant_for(study.id, sub.submission_id, sub.prolific_pid)
        row = rows.get(person.id) if person is not None else None
        action, reason, category, message, why = _propose(row, sub.status)
        if sub.pilot:
            action, reason = "none", "Prolific's test study"
        out.append(
            Proposal(
                submission_id=sub.submission_id,
                prolific_pid=sub.prolific_pid,
                status=sub.status,
                label=row.label if row is not None else "",
                facepair_status=row.status if row is not None else "no data",
                action=action,
                reason=reason,
                category=category,
                message=message,
                return_reason=why,
                decided=decided.get(sub.submission_id, []),
            )
        )
    # facepair's participants by arrival, then submissions with no facepair data
    return sorted(out, key=lambda p: (not p.label, p.label, p.submission_id))


@dataclass(frozen=True)
class Decision:
    """A person's decision on one submission."""

    submission_id: str
    action: str
    category: str = ""
    message: str = ""
    reasons: tuple[str, ...] = ()


def find_submission(study: Study, who: str) -> str:
    """The submission id of ``who``: a submission id, a Prolific ID or a label (``P0007``)."""
    who = who.strip()
    subs = db.session.scalars(
        sa.select(ProlificSubmission).where(ProlificSubmission.study_id == study.id)
    ).all()
    for sub in subs:
        if who in (sub.submission_id, sub.prolific_pid):
            return sub.submission_id
    for proposal in proposals(study):
        if proposal.label and proposal.label.upper() == who.upper():
            return proposal.submission_id
    raise InputError(
        f"no submission of this study for {who!r} (run 'facepair prolific sync' first?)",
        field="participant",
    )


def check(decision: Decision) -> None:
    """Refuse, in one line, a decision Prolific would refuse."""
    if decision.action not in ACTIONS:
        raise InputError(
            f"expected one of {', '.join(ACTIONS)}, got {decision.action!r}", field="action"
        )
    if decision.action == "reject":
        if decision.category not in REJECTION_CATEGORIES:
            raise InputError(
                f"expected one of {', '.join(REJECTION_CATEGORIES)}, got {decision.category!r}",
                field="category",
            )
        if len(decision.message.strip()) < MIN_MESSAGE:
            raise InputError(
                f"Prolific needs a message of at least {MIN_MESSAGE} characters for a rejection, "
                f"got {len(decision.message.strip())}",
                field="message",
            )
    if decision.action == "return":
        reasons = [r.strip() for r in decision.reasons if r.strip()]
        if not reasons or any(len(r) > 500 for r in reasons):
            raise InputError(
                "give at least one reason (at most 500 characters each)", field="reason"
            )


def decide(
    study: Study, decisions: Iterable[Decision], *, who: str
) -> list[tuple[ProlificCall, bool]]:
    """Write the decisions to the outbox (committed); a submission takes one decision (a second,
    different one is refused while the first is not cancelled or failed)."""
    decisions = list(decisions)
    known = {
        s.submission_id: s
        for s in db.session.scalars(
            sa.select(ProlificSubmission).where(ProlificSubmission.study_id == study.id)
        )
    }
    intents = []
    for decision in decisions:
        sub = known.get(decision.submission_id)
        if sub is None:
            raise InputError(
                f"no submission {decision.submission_id!r} in this study", field="participant"
            )
        key = f"{study.id}:{decision.action}:{sub.submission_id}"
        if db.session.scalar(sa.select(ProlificCall.id).where(ProlificCall.key == key)):
            # decided before (a command run again): the decision stands as written
            intents.append(Intent(decision.action, key, {}, sub.submission_id))
            continue
        check(decision)
        others = db.session.scalars(
            sa.select(ProlificCall).where(
                ProlificCall.study_id == study.id,
                ProlificCall.target == sub.submission_id,
                ProlificCall.kind.in_(ACTIONS),
                ProlificCall.kind != decision.action,
                ProlificCall.state.not_in(("cancelled", "failed")),
            )
        ).first()
        if others is not None:
            raise InputError(
                f"{sub.prolific_pid or sub.submission_id} already has a decision: {others.kind} "
                f"(call #{others.id}, {others.state}); cancel it first",
                field="participant",
            )
        if decision.action == "approve":
            payload: dict[str, object] = {}
        elif decision.action == "reject":
            payload = {
                "action": "REJECT",
                "message": decision.message.strip(),
                "rejection_category": decision.category,
            }
        else:
            payload = {"request_return_reasons": [r.strip() for r in decision.reasons if r.strip()]}
        intents.append(Intent(decision.action, key, dict(payload), sub.submission_id))
    return record(study.id, intents, created_by=who)


def approve_proposed(study: Study, *, who: str) -> list[tuple[ProlificCall, bool]]:
    """Bulk approval: every open submission whose proposal is to approve."""
    chosen = [
        Decision(p.submission_id, "approve")
        for p in proposals(study)
        if p.action == "approve" and p.open
    ]
    return decide(study, chosen, who=who) if chosen else []
