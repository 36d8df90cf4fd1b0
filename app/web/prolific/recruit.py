"""Publishing a study on Prolific and raising its places: the draft's body, the account's
currency and the cost, the calls written to the outbox.

The draft is made from the study file's ``[prolific]`` table (:mod:`app.trials.recruiting`)
with facepair's participant link carrying Prolific's ``{{%PROLIFIC_PID%}}``,
``{{%STUDY_ID%}}`` and ``{{%SESSION_ID%}}`` (``app.web.study.recruitment``), the study's
completion code (manual review, so nobody is paid before facepair's verdict) and, when the
attention stop rule has one, its screened-out code. The currency is the workspace's
(``GET /api/v1/workspaces/{id}/balance/``: rewards are in its minor units); the cost is
Prolific's calculator's (``POST /api/v1/study-cost-calculator/``, fees and VAT included).
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path
from typing import Any

import sqlalchemy as sa

from app.errors import InputError
from app.trials.fields import FieldReader
from app.trials.recruiting import MAX_PLACES, RecruitingSpec, read_recruiting
from app.web.extensions import db
from app.web.models import Study
from app.web.prolific.client import ProlificClient
from app.web.prolific.models import ProlificCall, ProlificStudy, ProlificSubmission
from app.web.prolific.outbox import Intent, record
from app.web.study.enrolment import dropped_after
from app.web.study.participants import participant_table
from app.web.study.recruitment import COMPLETION_BASE, prolific_study_url
from app.web.study.studies import participation


def recruiting_spec(
    study: Study, text: str | None = None, *, source: str = "study file"
) -> RecruitingSpec:
    """The ``[prolific]`` table of ``text`` (a study file or a file with that table alone),
    else of the study file ``study`` was made from."""
    text = study.source_toml if text is None else text
    try:
        data = tomllib.loads(text or "")
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"invalid TOML: {exc}", path=source) from None
    if "prolific" not in data:
        raise InputError(
            "no [prolific] table: add one (reward, places, minutes; docs/reference/studyfile.md) "
            "or give a file that has it",
            path=source,
        )
    return read_recruiting(FieldReader(source, Path(".")), data["prolific"])


def money(minor: int | float, currency: str) -> str:
    """``4500, "GBP"`` -> ``"45.00 GBP"``."""
    return f"{Decimal(int(round(minor))) / 100:.2f} {currency}".strip()


@dataclass(frozen=True)
class Account:
    workspace_id: str
    currency: str
    #: Minor units.
    available: int


def account(client: ProlificClient, spec: RecruitingSpec) -> Account:
    """The workspace the study is made in and its currency, refused if the study file names
    another currency (peers paid in pounds meaning dollars)."""
    workspace = spec.workspace or os.environ.get("PROLIFIC_WORKSPACE_ID", "")
    if not workspace:
        found = client.get("/api/v1/workspaces/", call="list workspaces")
        results = found.get("results", []) if isinstance(found, dict) else []
        ids = [str(w.get("id")) for w in results if isinstance(w, dict) and w.get("id")]
        if len(ids) != 1:
            raise InputError(
                f"the token sees {len(ids)} workspaces ({', '.join(ids) or 'none'}): name one as "
                "[prolific] workspace or PROLIFIC_WORKSPACE_ID",
                field="prolific.workspace",
            )
        workspace = ids[0]
    balance = client.get(f"/api/v1/workspaces/{workspace}/balance/", call="read the balance")
    currency = str((balance or {}).get("currency_code", "")).upper()
    if not currency:
        raise InputError(
            f"Prolific gave no currency for workspace {workspace}", field="prolific.workspace"
        )
    if spec.currency and spec.currency != currency:
        raise InputError(
            f"the study file says {spec.currency}, the workspace pays in {currency}: rewards and "
            "bonuses would be in the wrong currency",
            field="prolific.currency",
        )
    return Account(workspace, currency, int((balance or {}).get("available_balance") or 0))


def quote(client: ProlificClient, reward: int, places: int) -> int:
    """Prolific's cost of ``places`` at ``reward`` (minor units), fees and VAT included."""
    data = client.request(
        "POST",
        "/api/v1/study-cost-calculator/",
        call="calculate the cost",
        json={"reward": reward, "total_available_places": places},
    ).data
    return int(round(float((data or {}).get("total_cost", 0))))


def internal_name(study: Study, *, pilot: bool) -> str:
    """The draft's internal name: how a draft made before a crash is found again."""
    return f"{study.title[:120]} [facepair {study.slug[:12]} {'pilot' if pilot else 'live'}]"


def draft_body(study: Study, spec: RecruitingSpec, link: str, *, pilot: bool) -> dict[str, Any]:
    """The ``CreateStudy`` body (``_pilot`` stays home: ``calls.public``)."""
    if not study.completion_code:
        raise InputError(
            "the study has no completion_code: Prolific needs one", field="completion_code"
        )
    if study.redirect_url and not study.redirect_url.startswith(COMPLETION_BASE):
        raise InputError(
            "redirect_url sends finished participants away from Prolific's completion page, so "
            "Prolific would never see them finish: remove it",
            field="redirect_url",
        )
    codes = [
        {
            "code": study.completion_code,
            "code_type": "COMPLETED",
            "actions": [{"action": "MANUALLY_REVIEW"}],
        }
    ]
    screened = participation(study).screened_out_code
    if screened and screened != study.completion_code:
        codes.append(
            {
                "code": screened,
                "code_type": "FAILED_ATTENTION_CHECK",
                "actions": [{"action": "MANUALLY_REVIEW"}],
            }
        )
    body: dict[str, Any] = {
        "name": spec.name or study.title,
        "internal_name": internal_name(study, pilot=pilot),
        "description": spec.description or study.instructions or study.question,
        "external_study_url": prolific_study_url(link),
        "prolific_id_option": "url_parameters",
        "completion_codes": codes,
        "total_available_places": spec.places,
        "estimated_completion_time": spec.minutes,
        "reward": spec.reward,
        "device_compatibility": list(spec.devices),
        "peripheral_requirements": list(spec.peripherals),
        "submissions_config": {"max_submissions_per_participant": 1},
        "_pilot": pilot,
    }
    if spec.max_minutes is not None:
        body["maximum_allowed_time"] = spec.max_minutes
    if spec.filters:
        body["filters"] = [dict(f) for f in spec.filters]
    if spec.project:
        body["project"] = spec.project
    return body


def prolific_study(study: Study, *, pilot: bool = False) -> ProlificStudy | None:
    return db.session.scalar(
        sa.select(ProlificStudy).where(
            ProlificStudy.study_id == study.id, ProlificStudy.pilot == pilot
        )
    )


def draft(
    study: Study, spec: RecruitingSpec, link: str, acct: Account, *, pilot: bool, who: str
) -> tuple[ProlificStudy, ProlificCall]:
    """The Prolific study's row and the outbox's create call (written once; committed)."""
    row = prolific_study(study, pilot=pilot)
    if row is None:
        row = ProlificStudy(study_id=study.id, pilot=pilot)
        db.session.add(row)
    if row.prolific_id is None:
        row.places, row.reward = spec.places, spec.reward
        row.currency, row.workspace_id = acct.currency, acct.workspace_id
    db.session.commit()
    body = draft_body(study, spec, link, pilot=pilot)
    ((create, _),) = record(
        study.id,
        [Intent("create", f"{study.id}:create:{'pilot' if pilot else 'live'}", body)],
        created_by=who,
    )
    return row, create


def go_live(study: Study, create: ProlificCall, *, pilot: bool, who: str) -> ProlificCall:
    """The call that opens the draft to participants: ``PUBLISH``, or for the pilot Prolific's
    test study. Committed."""
    kind = "test_study" if pilot else "publish"
    payload: dict[str, Any] = {"_pilot": pilot} if pilot else {"action": "PUBLISH", "_pilot": False}
    ((row, _),) = record(
        study.id,
        [Intent(kind, f"{study.id}:{kind}", payload, create.result_id, create)],
        created_by=who,
    )
    return row


@dataclass(frozen=True)
class TopUp:
    """What the stop rule says of the places: ``proposed`` > ``current`` when more are needed."""

    target: int
    counted: int
    in_flight: int
    free: int
    current: int
    proposed: int


def topup_proposal(study: Study, *, target: int | None = None) -> TopUp:
    """Places needed for ``target`` participants the analysis counts (the study's
    ``target_participants`` unless a plan says otherwise): counted ones, submissions still
    under way and places Prolific refills by itself (returned, rejected and timed-out
    submissions free their place) are subtracted."""
    row = prolific_study(study)
    if row is None or row.prolific_id is None:
        raise InputError("the study is not on Prolific yet: publish it first", field="STUDY_ID")
    goal = study.target_participants if target is None else target
    rows = participant_table(study, dropped_after=dropped_after())
    counted = sum(1 for r in rows if r.status == "finished" and not r.excluded and not r.pilot)
    statuses = db.session.scalars(
        sa.select(ProlificSubmission.status).where(
            ProlificSubmission.study_id == study.id, ProlificSubmission.pilot.is_(False)
        )
    ).all()
    in_flight = sum(1 for s in statuses if s in ("RESERVED", "ACTIVE"))
    taken = sum(1 for s in statuses if s not in ("RETURNED", "TIMED-OUT", "REJECTED"))
    free = max(0, row.places - taken)
    shortfall = goal - counted - in_flight - free
    return TopUp(goal, counted, in_flight, free, row.places, row.places + max(0, shortfall))


def topup_call(study: Study, places: int, *, who: str) -> tuple[ProlificCall, bool]:
    """The outbox call raising the places to ``places`` (Prolific only ever raises them)."""
    row = prolific_study(study)
    if row is None or row.prolific_id is None:
        raise InputError("the study is not on Prolific yet: publish it first", field="STUDY_ID")
    if places <= row.places:
        raise InputError(
            f"the study has {row.places} places; Prolific only raises them", field="places"
        )
    if places > MAX_PLACES:
        raise InputError(f"at most {MAX_PLACES} places, got {places}", field="places")
    ((call, new),) = record(
        study.id,
        [
            Intent(
                "top_up",
                f"{study.id}:top_up:{places}",
                {"total_available_places": places},
                row.prolific_id,
            )
        ],
        created_by=who,
    )
    return call, new
