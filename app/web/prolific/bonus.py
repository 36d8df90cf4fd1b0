"""Bonuses: a CSV of Prolific IDs and amounts (or the study file's rule, an amount per correct
attention check), set up as Prolific bonus batches and each paid once.

Prolific pays bonuses in two calls (its OpenAPI document, "Set up bonuses" and "Pay
bonuses"): ``POST /api/v1/submissions/bonus-payments/`` with ``csv_bonuses`` lines
``<participant_id>,<amount>`` in the **study's currency, major unit** (``4.25`` is 4.25, not
4.25 pence) sets up a batch; ``POST /api/v1/bulk-bonus-payments/{id}/pay/`` pays it and is not
idempotent. Here a batch's identity is the digest of its sorted lines: the same file (or the
same rule's result) finds the batch and payment already written, so a second run pays
nothing. Batches hold at most :data:`BATCH` participants (Prolific recommends 200).
"""

from __future__ import annotations

import csv
import hashlib
import io
from dataclasses import dataclass
from decimal import Decimal

import sqlalchemy as sa

from app.errors import InputError
from app.trials.recruiting import MAX_BONUS, money
from app.web.extensions import db
from app.web.models import Participant, Study, Trial, Vote
from app.web.prolific.models import ProlificCall, ProlificSubmission
from app.web.prolific.outbox import Intent, record
from app.web.prolific.recruit import prolific_study

BATCH = 200
MAX_LINES = 20_000


def parse_bonus_csv(text: str, *, source: str = "bonus CSV") -> dict[str, Decimal]:
    """``participant_id,amount`` lines (an optional header line, blank lines ignored) ->
    amounts by Prolific ID. A repeated ID, a bad amount or an amount above
    :data:`app.trials.recruiting.MAX_BONUS` is one line naming the row."""
    out: dict[str, Decimal] = {}
    try:
        rows = list(csv.reader(io.StringIO(text, newline="")))
    except csv.Error as exc:
        raise InputError(f"not a CSV file: {exc}", path=source) from None
    if len(rows) > MAX_LINES:
        raise InputError(f"at most {MAX_LINES} lines, got {len(rows)}", path=source)
    for number, cells in enumerate(rows, start=1):
        cells = [c.strip() for c in cells]
        if not any(cells):
            continue
        if len(cells) != 2:
            raise InputError(
                f"expected participant_id,amount, got {len(cells)} cells", path=source, line=number
            )
        pid, amount = cells
        value = money(amount)
        if value is None:
            if number == 1 and not any(c.isdigit() for c in amount):  # a header line
                continue
            raise InputError(
                f"expected an amount such as 1.50, got {amount!r}", path=source, line=number
            )
        if value > MAX_BONUS:
            raise InputError(
                f"{value} is more than the {MAX_BONUS} a bonus may be", path=source, line=number
            )
        if not pid.isascii() or not pid.isalnum() or len(pid) > 64:
            raise InputError(f"expected a Prolific ID, got {pid!r}", path=source, line=number)
        if pid in out:
            raise InputError(f"{pid} appears twice", path=source, line=number)
        out[pid] = value
    if not out:
        raise InputError("no bonuses in it", path=source)
    return out


def rule_bonuses(study: Study, per_check: Decimal) -> dict[str, Decimal]:
    """The rule's bonuses: ``per_check`` for every catch trial answered as expected, to each
    non-pilot participant with a Prolific ID (pair designs: votes on catch trials)."""
    counts = db.session.execute(
        sa.select(Participant.prolific_pid, sa.func.count(Vote.id))
        .join(Vote, Vote.participant_id == Participant.id)
        .join(Trial, Vote.trial_id == Trial.id)
        .where(
            Participant.study_id == study.id,
            Participant.pilot.is_(False),
            Participant.prolific_pid.is_not(None),
            Trial.kind == "catch",
            Vote.choice == Trial.expected,
        )
        .group_by(Participant.prolific_pid)
    ).all()
    return {str(pid): (per_check * n).quantize(Decimal("0.01")) for pid, n in counts if n}


@dataclass
class Batch:
    """One batch: its lines, its setup call and, once confirmed, its payment."""

    bonuses: dict[str, Decimal]
    setup: ProlificCall
    pay: ProlificCall | None
    new: bool

    @property
    def total(self) -> Decimal:
        return sum(self.bonuses.values(), Decimal("0"))


def _lines(bonuses: dict[str, Decimal]) -> str:
    return "".join(f"{pid},{amount:.2f}\n" for pid, amount in sorted(bonuses.items()))


def _digest(bonuses: dict[str, Decimal]) -> str:
    return hashlib.sha256(_lines(bonuses).encode()).hexdigest()[:32]


def batches(study: Study, bonuses: dict[str, Decimal], *, who: str) -> list[Batch]:
    """Write each batch's setup call (once per content; committed) and find its payment call
    if one was written before. Participants must have taken part in the Prolific study."""
    link = prolific_study(study)
    if link is None or link.prolific_id is None:
        raise InputError("the study is not on Prolific yet: publish it first", field="STUDY_ID")
    known = set(
        db.session.scalars(
            sa.select(ProlificSubmission.prolific_pid).where(
                ProlificSubmission.study_id == study.id
            )
        )
    ) | set(
        db.session.scalars(
            sa.select(Participant.prolific_pid).where(
                Participant.study_id == study.id, Participant.prolific_pid.is_not(None)
            )
        )
    )
    strangers = sorted(set(bonuses) - known)
    if strangers:
        raise InputError(
            f"{len(strangers)} Prolific ID(s) did not take part in this study: "
            f"{', '.join(strangers[:5])}{' ...' if len(strangers) > 5 else ''}",
            field="participant_id",
        )
    items = sorted(bonuses.items())
    out = []
    for start in range(0, len(items), BATCH):
        part = dict(items[start : start + BATCH])
        digest = _digest(part)
        payload = {"study_id": link.prolific_id, "csv_bonuses": _lines(part)}
        ((setup, new),) = record(
            study.id, [Intent("bonus", f"{study.id}:bonus:{digest}", payload)], created_by=who
        )
        pay = db.session.scalar(
            sa.select(ProlificCall).where(ProlificCall.key == f"{study.id}:pay:{digest}")
        )
        out.append(Batch(part, setup, pay, new))
    return out


def pay(study: Study, batch: Batch, *, who: str) -> ProlificCall:
    """Write the payment of ``batch`` (once; committed): it is sent after its setup is done,
    to the batch id Prolific gave."""
    link = prolific_study(study)
    digest = _digest(batch.bonuses)
    payload = {
        "_study": link.prolific_id if link else "",
        "_bonuses": {pid: str(amount) for pid, amount in batch.bonuses.items()},
    }
    ((row, _),) = record(
        study.id,
        [Intent("pay", f"{study.id}:pay:{digest}", payload, depends_on=batch.setup)],
        created_by=who,
    )
    batch.pay = row
    return row


def earlier(study: Study, bonuses: dict[str, Decimal], exclude: set[int]) -> dict[str, list[str]]:
    """Bonuses already set up for these participants in other batches (to say so)."""
    out: dict[str, list[str]] = {}
    for call in db.session.scalars(
        sa.select(ProlificCall).where(
            ProlificCall.study_id == study.id,
            ProlificCall.kind == "bonus",
            ProlificCall.id.not_in(exclude or {0}),
        )
    ):
        for line in str((call.payload or {}).get("csv_bonuses", "")).splitlines():
            pid, _, amount = line.partition(",")
            if pid in bonuses:
                out.setdefault(pid, []).append(f"{amount} (call #{call.id}, {call.state})")
    return out
