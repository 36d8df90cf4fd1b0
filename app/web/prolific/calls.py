"""What each kind of outbox call sends to Prolific (:func:`send`), and how its effect is read
back from Prolific's state after a crash (:func:`observe`).

The endpoints and fields are those of Prolific's public OpenAPI document
(``https://docs.prolific.com/openapi.json``): ``POST /api/v1/studies/`` (a draft),
``POST /api/v1/studies/{id}/transition/`` (``PUBLISH``), ``POST /api/v1/studies/{id}/test-study``,
``PATCH /api/v1/studies/{id}/`` (``total_available_places``, only ever raised),
``POST /api/v1/submissions/bulk-approve/`` (``submission_ids``),
``POST /api/v1/submissions/{id}/transition/`` (``REJECT`` with ``message`` of at least 100
characters and ``rejection_category``; documented as idempotent),
``POST /api/v1/submissions/{id}/request-return/`` (``request_return_reasons``),
``POST /api/v1/submissions/bonus-payments/`` (``study_id``, ``csv_bonuses``: a batch, paid by)
``POST /api/v1/bulk-bonus-payments/{id}/pay/`` (documented as **not** idempotent).

What :func:`observe` reads: the study list's ``internal_name`` (a draft made before a crash),
the study's ``status`` and ``total_available_places``, a submission's ``status`` and
``return_requested``, and its ``bonus_payments`` (paid bonuses, in minor units) against the
baseline read before the payment was sent.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

import sqlalchemy as sa

from app.web.extensions import db
from app.web.prolific.client import ProlificClient, ProlificError
from app.web.prolific.models import ProlificCall, ProlificStudy

KINDS = ("create", "publish", "test_study", "approve", "reject", "return", "bonus", "pay", "top_up")
#: Submission statuses after which no approval, rejection or return request can follow.
FINAL = ("APPROVED", "REJECTED", "RETURNED", "TIMED-OUT", "SCREENED OUT", "PARTIALLY APPROVED")
#: Not yet submitted: an approval or rejection waits (Prolific refuses it before).
NOT_YET = ("RESERVED", "ACTIVE")
DOUBT_HINT = (
    "Prolific does not show this payment (yet: it pays asynchronously). Look at the study's "
    "bonuses on Prolific, then run 'facepair prolific resolve {id} --sent' or '--not-sent'"
)
#: The most submission ids one bulk approval carries (Prolific recommends at most 1,000).
BULK = 1000


@dataclass
class Outcome:
    note: str = ""
    result: dict[str, Any] | None = None
    result_id: str = ""
    target: str = ""


class Done(Outcome):
    """Prolific answered, or its state shows the call's effect."""


@dataclass
class Wait(Outcome):
    """Not sent, or not yet possible (a submission still active): try again later."""

    delay: float | None = None


class Failed(Outcome):
    """Prolific refused it; sending it again would be refused again."""


class Doubt(Outcome):
    """It may have been sent and Prolific's state does not tell: a person decides."""


def public(payload: dict[str, Any]) -> dict[str, Any]:
    """The body as sent: facepair's own notes (keys starting with ``_``) stay home."""
    return {k: v for k, v in payload.items() if not k.startswith("_")}


def _short(data: Any, keys: tuple[str, ...]) -> dict[str, Any]:
    return {k: data[k] for k in keys if isinstance(data, dict) and k in data}


STUDY_FIELDS = ("id", "status", "total_available_places", "reward", "internal_name")


def submission(client: ProlificClient, submission_id: str) -> dict[str, Any]:
    data = client.get(
        f"/api/v1/submissions/{submission_id}/", call=f"read submission {submission_id}"
    )
    return data if isinstance(data, dict) else {}


def study_submissions(client: ProlificClient, prolific_id: str) -> list[dict[str, Any]]:
    """Every submission of a Prolific study (``GET /api/v1/submissions/?study=``, paged)."""
    return list(
        client.pages(
            "/api/v1/submissions/",
            call=f"list submissions of {prolific_id}",
            params={"study": prolific_id},
        )
    )


def send(
    client: ProlificClient,
    row: ProlificCall,
    dependency: ProlificCall | None,
    *,
    prepared: Callable[[], None],
) -> Outcome:
    """Send ``row`` (claimed by the caller); raises the client's errors."""
    target = row.target or (dependency.result_id if dependency is not None else "")
    if row.kind not in ("create", "bonus") and not target:
        return Failed(f"nothing to act on: call #{row.depends_on_id} gave no id")
    body = public(row.payload or {})
    if row.kind == "create":
        data = client.request(
            "POST", "/api/v1/studies/", call="create the draft study", json=body, unsafe=True
        ).data
        return Done(
            "draft created",
            _short(data, STUDY_FIELDS),
            str(data.get("id", "")),
            str(data.get("id", "")),
        )
    if row.kind == "publish":
        try:
            data = client.request(
                "POST", f"/api/v1/studies/{target}/transition/", call="publish", json=body
            ).data
        except ProlificError as exc:
            if exc.status is not None and 400 <= exc.status < 500:
                seen = _observe_publish(client, target)
                if seen is not None:
                    return seen
            raise
        return Done("published", _short(data, STUDY_FIELDS), target, target)
    if row.kind == "test_study":
        data = client.request(
            "POST",
            f"/api/v1/studies/{target}/test-study",
            call="create the test study",
            unsafe=True,
        ).data
        made = str(data.get("study_id", "")) if isinstance(data, dict) else ""
        return Done("test study made", _short(data, ("study_id", "study_url")), made, target)
    if row.kind == "reject":
        return _reject(client, row, target, body)
    if row.kind == "return":
        data = client.request(
            "POST",
            f"/api/v1/submissions/{target}/request-return/",
            call="request a return",
            json=body,
            unsafe=True,
        ).data
        return Done(
            "return requested", _short(data, ("id", "status", "return_requested")), target=target
        )
    if row.kind == "bonus":
        data = client.request(
            "POST",
            "/api/v1/submissions/bonus-payments/",
            call="set up the bonus batch",
            json=body,
            unsafe=True,
        ).data
        keys = ("id", "amount", "fees", "vat", "total_amount")
        return Done("bonus batch set up (not paid)", _short(data, keys), str(data.get("id", "")))
    if row.kind == "pay":
        return _pay(client, row, target, prepared)
    if row.kind == "top_up":
        places = int(body["total_available_places"])
        seen = _observe_places(client, target, places)
        if seen is not None:
            return seen
        data = client.request(
            "PATCH", f"/api/v1/studies/{target}/", call="raise the places", json=body
        ).data
        return Done(f"places raised to {places}", _short(data, STUDY_FIELDS), target=target)
    return Failed(f"unknown kind {row.kind!r}")


def _reject(
    client: ProlificClient, row: ProlificCall, target: str, body: dict[str, Any]
) -> Outcome:
    status = submission(client, target).get("status", "")
    if status == "REJECTED":
        return Done("already rejected", target=target)
    if status in NOT_YET:
        return Wait(f"the submission is {status}: the rejection waits until it is awaiting review")
    if status != "AWAITING REVIEW":
        return Failed(f"the submission is {status or 'unknown'}: nothing to reject")
    data = client.request(
        "POST", f"/api/v1/submissions/{target}/transition/", call="reject", json=body
    ).data
    return Done("rejected", _short(data, ("id", "status")), target=target)


def approve_in_bulk(client: ProlificClient, rows: list[ProlificCall]) -> dict[int, Outcome]:
    """Approve the submissions of ``rows`` Prolific has awaiting review, in bulk; the others
    wait or fail (Dallinger's lesson: approving before Prolific has the submission fails)."""
    prolific_ids = db.session.scalars(
        sa.select(ProlificStudy.prolific_id).where(
            ProlificStudy.study_id.in_({r.study_id for r in rows}),
            ProlificStudy.prolific_id.is_not(None),
        )
    ).all()
    tests = db.session.scalars(
        sa.select(ProlificStudy.test_study_id).where(
            ProlificStudy.study_id.in_({r.study_id for r in rows}),
            ProlificStudy.test_study_id.is_not(None),
        )
    ).all()
    status: dict[str, str] = {}
    for prolific_id in [*prolific_ids, *tests]:
        for item in study_submissions(client, str(prolific_id)):
            status[str(item.get("id"))] = str(item.get("status", ""))
    outcomes: dict[int, Outcome] = {}
    ready: list[ProlificCall] = []
    for row in rows:
        now = status.get(row.target)
        if now is None:
            outcomes[row.id] = Wait("Prolific does not list this submission yet")
        elif now == "APPROVED":
            outcomes[row.id] = Done("already approved")
        elif now == "AWAITING REVIEW":
            ready.append(row)
        elif now in NOT_YET:
            outcomes[row.id] = Wait(
                f"the submission is {now}: the approval waits until it is awaiting review"
            )
        else:
            outcomes[row.id] = Failed(f"the submission is {now}: nothing to approve")
    for start in range(0, len(ready), BULK):
        chunk = ready[start : start + BULK]
        client.request(
            "POST",
            "/api/v1/submissions/bulk-approve/",
            call=f"approve {len(chunk)} submission(s)",
            json={"submission_ids": [r.target for r in chunk]},
        )
        for row in chunk:
            outcomes[row.id] = Done("approval accepted (Prolific approves in bulk, asynchronously)")
    return outcomes


def _amounts(row: ProlificCall) -> dict[str, int]:
    """The batch's bonuses in minor units, by Prolific ID."""
    return {
        pid: int(Decimal(amount) * 100)
        for pid, amount in (row.payload.get("_bonuses") or {}).items()
    }


def _paid(client: ProlificClient, row: ProlificCall) -> dict[str, list[int]]:
    """The bonus payments Prolific shows on each participant's submission of the batch's study."""
    prolific_study = str(row.payload.get("_study", ""))
    wanted = _amounts(row)
    out: dict[str, list[int]] = {pid: [] for pid in wanted}
    for item in study_submissions(client, prolific_study):
        pid = str(item.get("participant_id", ""))
        if pid in wanted:
            detail = submission(client, str(item.get("id")))
            out[pid] += [int(round(float(x))) for x in detail.get("bonus_payments") or []]
    return out


def _pay(
    client: ProlificClient, row: ProlificCall, batch: str, prepared: Callable[[], None]
) -> Outcome:
    # The baseline first, kept before anything is sent: after a crash it tells a payment sent
    # (the bonuses have grown) from one never sent (no baseline kept).
    before = _paid(client, row)
    db.session.execute(
        sa.update(ProlificCall)
        .where(ProlificCall.id == row.id)
        .values(result={"before": before, "batch": batch})
    )
    db.session.commit()
    prepared()
    client.request(
        "POST",
        f"/api/v1/bulk-bonus-payments/{batch}/pay/",
        call=f"pay bonus batch {batch}",
        unsafe=True,
    )
    return Done(
        "paid (Prolific pays asynchronously)", {"before": before, "batch": batch}, target=batch
    )


def observe(client: ProlificClient, row: ProlificCall) -> Outcome | None:
    """Prolific's state for ``row``: :class:`Done` if it shows the call's effect, None if it
    shows it was not done and sending again is safe, :class:`Doubt` if it cannot tell."""
    target = row.target or (row.depends_on.result_id if row.depends_on is not None else "")
    if row.kind == "create":
        wanted = (row.payload or {}).get("internal_name")
        data = client.get("/api/v1/studies/", call="find the draft study")
        for item in (data or {}).get("results", []) if isinstance(data, dict) else []:
            if isinstance(item, dict) and item.get("internal_name") == wanted:
                found = str(item.get("id", ""))
                return Done(
                    "found at Prolific (made before a crash)",
                    _short(item, STUDY_FIELDS),
                    found,
                    found,
                )
        return None
    if row.kind == "publish":
        return _observe_publish(client, target) if target else None
    if row.kind in ("test_study", "bonus"):
        # a second test study reaches only test participants; a second batch is never paid
        return None
    if row.kind in ("approve", "reject", "return"):
        data = submission(client, target)
        status = data.get("status")
        if row.kind == "approve" and status == "APPROVED":
            return Done("Prolific shows it approved", target=target)
        if row.kind == "reject" and status == "REJECTED":
            return Done("Prolific shows it rejected", target=target)
        if row.kind == "return" and (data.get("return_requested") or status == "RETURNED"):
            return Done("Prolific shows the return requested", target=target)
        return None
    if row.kind == "top_up":
        places = int((row.payload or {}).get("total_available_places", 0))
        return _observe_places(client, target, places) if target else None
    if row.kind == "pay":
        before = (row.result or {}).get("before")
        if before is None:
            return None  # the baseline is kept before the payment is sent: it was not sent
        now = _paid(client, row)
        grown = all(
            now.get(pid, []).count(cents) > list(before.get(pid, [])).count(cents)
            for pid, cents in _amounts(row).items()
        )
        if grown:
            return Done("Prolific shows the bonuses paid", {**(row.result or {}), "after": now})
        return Doubt(DOUBT_HINT.format(id=row.id))
    return None


def _observe_publish(client: ProlificClient, target: str) -> Outcome | None:
    data = client.get(f"/api/v1/studies/{target}/", call=f"read study {target}")
    status = data.get("status") if isinstance(data, dict) else None
    if status and status != "UNPUBLISHED":
        return Done(f"Prolific shows it {status}", _short(data, STUDY_FIELDS), target, target)
    return None


def _observe_places(client: ProlificClient, target: str, places: int) -> Outcome | None:
    data = client.get(f"/api/v1/studies/{target}/", call=f"read study {target}")
    have = data.get("total_available_places") if isinstance(data, dict) else None
    if isinstance(have, int | float) and have >= places:
        return Done(f"Prolific has {int(have)} places", _short(data, STUDY_FIELDS), target=target)
    return None


def after_done(kind: str, row: ProlificCall | None, outcome: Outcome) -> None:
    """Keep what a done call tells on the Prolific study's row (not committed)."""
    if row is None:
        return
    pilot = bool((row.payload or {}).get("_pilot"))
    link = db.session.scalar(
        sa.select(ProlificStudy).where(
            ProlificStudy.study_id == row.study_id, ProlificStudy.pilot == pilot
        )
    )
    if link is None:
        return
    result = outcome.result or {}
    if kind == "create" and outcome.result_id:
        link.prolific_id = outcome.result_id
        link.status = str(result.get("status") or "UNPUBLISHED")
    elif kind == "publish":
        link.status = str(result.get("status") or "ACTIVE")
    elif kind == "test_study" and outcome.result_id:
        link.test_study_id = outcome.result_id
    elif kind == "top_up":
        link.places = max(link.places, int((row.payload or {}).get("total_available_places", 0)))
