"""A fake Prolific API v1 on loopback, for the tests: the operations facepair calls, with the
behaviour Prolific documents for them, every request (and every answer) validated against
``tests/web/prolific/openapi-subset.yaml`` (the public OpenAPI document's shapes).

What it models: studies (draft -> PUBLISH -> ACTIVE, places only raised, test studies),
submissions (RESERVED/ACTIVE -> AWAITING REVIEW -> APPROVED/REJECTED; RETURNED, TIMED-OUT),
approval only of submissions awaiting review (400 before, as peers found), the transition
endpoint's idempotency, bulk approval, return requests, bonus batches set up in major units and
paid in minor units (paying twice pays twice: the endpoint is not idempotent), webhook secrets
and subscriptions, paging (``page``, ``page_size``, ``_links``). Faults: a storm of 429s, 5xx
answers, and a crash after the effect (the answer never reaches the client).

Counts of effects (``effects``) are what the tests compare: a call applied twice shows as 2.
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import itertools
import json
import re
import threading
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from decimal import Decimal
from pathlib import Path
from typing import Any

import yaml
from jsonschema import Draft202012Validator
from werkzeug.wrappers import Request, Response

from tests.support.liveserver import serve

SPEC = yaml.safe_load(
    (Path(__file__).resolve().parents[1] / "web" / "prolific" / "openapi-subset.yaml").read_text()
)
TOKEN = "test-token-5f3c9a"  # a fake token: the tests check it never leaks
_ids = itertools.count(1)


def new_id() -> str:
    return f"{next(_ids):024x}"


def _routes() -> list[tuple[re.Pattern[str], str, dict[str, Any]]]:
    out = []
    for template, item in SPEC["paths"].items():
        pattern = re.compile("^" + re.sub(r"\{[^}]+\}", "([^/]+)", template) + "$")
        out.append((pattern, template, item))
    # literal segments before parameters: bulk-approve/ is not a submission id
    return sorted(out, key=lambda route: route[1].count("{"))


ROUTES = _routes()


def _validate(instance: Any, schema: dict[str, Any]) -> list[str]:
    wrapped = {"allOf": [schema], "components": SPEC["components"]}
    return [
        f"{'/'.join(map(str, e.absolute_path)) or '(body)'}: {e.message[:200]}"
        for e in Draft202012Validator(wrapped).iter_errors(instance)
    ]


def _refusal(status: int, detail: str) -> dict[str, Any]:
    """Prolific's ``Error`` body."""
    title = {400: "Bad Request", 404: "Not Found"}.get(status, "Error")
    return {
        "error": {"status": status, "error_code": status * 100, "title": title, "detail": detail}
    }


def sign(secret: str, timestamp: str, body: bytes) -> str:
    """Prolific's webhook signature (its "Verifying" guide): base64 HMAC-SHA256 of the
    timestamp followed by the body."""
    return base64.b64encode(
        hmac.new(secret.encode(), timestamp.encode() + body, hashlib.sha256).digest()
    ).decode()


class FakeProlific:
    """The fake service: state, faults and a WSGI app (``__call__``)."""

    def __init__(self, currency: str = "GBP") -> None:
        self.lock = threading.RLock()
        self.workspace = {"id": new_id(), "title": "Lab", "currency": currency, "balance": 100_000}
        self.studies: dict[str, dict[str, Any]] = {}
        self.submissions: dict[str, dict[str, Any]] = {}
        self.batches: dict[str, dict[str, Any]] = {}
        self.secret = ""
        self.subscriptions: dict[str, dict[str, Any]] = {}
        self.requests: list[tuple[str, str, Any]] = []
        self.violations: list[str] = []
        #: (effect, key) -> times applied: ("create", internal name), ("publish", study),
        #: ("approve", submission), ("reject", ...), ("return", ...), ("pay", batch), ...
        self.effects: Counter[tuple[str, str]] = Counter()
        self.storm = 0  # the next N requests answer 429
        self.delay = 0.0  # seconds each request takes (widens races)
        self.fail_next: list[tuple[str, int]] = []  # (path regex, status) answered once
        self.crash_after: list[str] = []  # path regexes: apply, then drop the answer (500)

    # -- what participants do (not the API) --------------------------------------------------

    def start(self, study_id: str, pid: str | None = None) -> tuple[str, str]:
        """A participant takes a place; returns (submission id, Prolific ID)."""
        with self.lock:
            pid = pid or new_id()
            sid = new_id()
            self.submissions[sid] = {
                "id": sid,
                "participant_id": pid,
                "study_id": study_id,
                "status": "ACTIVE",
                "started_at": "2026-12-01T10:00:00Z",
                "completed_at": None,
                "study_code": None,
                "return_requested": None,
                "bonus_payments": [],
            }
            return sid, pid

    def submit(self, sid: str, code: str) -> None:
        with self.lock:
            self.submissions[sid].update(
                status="AWAITING REVIEW", completed_at="2026-12-01T10:20:00Z", study_code=code
            )

    def set_status(self, sid: str, status: str) -> None:
        with self.lock:
            self.submissions[sid]["status"] = status

    def count(self, effect: str) -> int:
        return sum(n for (kind, _), n in self.effects.items() if kind == effect)

    # -- the API ------------------------------------------------------------------------------

    def __call__(self, environ: dict[str, Any], start_response: Any) -> Any:
        request = Request(environ)
        response = self.handle(request)
        return response(environ, start_response)

    def _error(self, status: int, detail: str) -> Response:
        body = {
            "error": {
                "status": status,
                "error_code": status * 100,
                "title": "Error",
                "detail": detail,
            }
        }
        return Response(json.dumps(body), status=status, mimetype="application/json")

    def handle(self, request: Request) -> Response:
        path, method = request.path, request.method.lower()
        body = request.get_json(silent=True) if request.data else None
        if self.delay:
            time.sleep(self.delay)
        with self.lock:
            self.requests.append((method.upper(), path, body))
            if request.headers.get("Authorization") != f"Token {TOKEN}":
                return self._error(401, "Invalid token.")
            if self.storm > 0:
                self.storm -= 1
                return Response(
                    "{}", status=429, headers={"Retry-After": "0"}, mimetype="application/json"
                )
            for failing, status in list(self.fail_next):
                if re.search(failing, path):
                    self.fail_next.remove((failing, status))
                    return self._error(status, "Something went wrong")
            route = next(((p, t, i) for p, t, i in ROUTES if p.match(path)), None)
            if route is None or method not in route[2]:
                self.violations.append(f"{method.upper()} {path}: not in Prolific's API")
                return self._error(404, "Not found.")
            pattern, template, item = route
            operation = item[method]
            problems = self._check_request(operation, request, body)
            if problems:
                self.violations.extend(f"{method.upper()} {template}: {p}" for p in problems)
                return self._error(400, "; ".join(problems))
            args = pattern.match(path).groups()  # type: ignore[union-attr]
            name = operation["operationId"].replace("-", "_")
            status, answer, headers = getattr(self, name)(*args, body=body, query=request.args)
            if 200 <= status < 300:
                self._check_response(operation, status, answer, f"{method.upper()} {template}")
            if any(re.search(p, path) for p in self.crash_after):
                return self._error(502, "Bad gateway")  # applied, but the answer is lost
            return Response(
                json.dumps(answer), status=status, headers=headers, mimetype="application/json"
            )

    def _check_request(self, operation: dict[str, Any], request: Request, body: Any) -> list[str]:
        problems = []
        declared = {p["name"]: p for p in operation.get("parameters", []) if p["in"] == "query"}
        for key in request.args:
            if key not in declared:
                problems.append(f"query {key}: not a parameter of this operation")
        for key, param in declared.items():
            if param.get("required") and key not in request.args:
                problems.append(f"query {key}: required")
        schema = operation.get("requestBody", {}).get("content", {}).get("application/json", {})
        if "schema" in schema:
            if body is None:
                problems.append("body: a JSON body is required")
            else:
                problems += _validate(body, schema["schema"])
        elif request.data:
            problems.append("body: this operation takes none")
        return problems

    def _check_response(
        self, operation: dict[str, Any], status: int, answer: Any, name: str
    ) -> None:
        content = operation["responses"].get(str(status), {}).get("content", {})
        schema = content.get("application/json", {}).get("schema")
        if schema is None:
            self.violations.append(f"{name}: the fake answered {status}, not documented")
        else:
            self.violations += [f"{name} (fake's answer): {p}" for p in _validate(answer, schema)]

    # operations, named by Prolific's operationId

    def get_user(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        return 200, {"id": "researcher1", "email": "lab@example.org"}, {}

    def get_workspaces(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        ws = self.workspace
        return 200, {"results": [{"id": ws["id"], "title": ws["title"]}]}, {}

    def get_workspace_balance(
        self, workspace_id: str, *, body: Any, query: Any
    ) -> tuple[int, Any, dict]:
        if workspace_id != self.workspace["id"]:
            return (
                404,
                _refusal(404, "no"),
                {},
            )
        ws = self.workspace
        return (
            200,
            {
                "currency_code": ws["currency"],
                "total_balance": ws["balance"],
                "available_balance": ws["balance"],
            },
            {},
        )

    def calculate_study_cost(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        rewards = body["reward"] * body["total_available_places"]
        return 200, {"total_cost": round(rewards * 1.42)}, {}

    def _study(self, study: dict[str, Any]) -> dict[str, Any]:
        keep = (
            "id",
            "name",
            "internal_name",
            "description",
            "external_study_url",
            "prolific_id_option",
            "completion_codes",
            "total_available_places",
            "estimated_completion_time",
            "reward",
            "device_compatibility",
            "peripheral_requirements",
            "status",
        )
        return {k: study[k] for k in keep if k in study}

    def get_studies(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        short = ("id", "name", "internal_name", "status", "total_available_places", "reward")
        return (
            200,
            {"results": [{k: s[k] for k in short if k in s} for s in self.studies.values()]},
            {},
        )

    def create_study(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        study = {**body, "id": new_id(), "status": "UNPUBLISHED"}
        self.studies[study["id"]] = study
        self.effects[("create", body.get("internal_name") or study["id"])] += 1
        return 201, self._study(study), {}

    def get_study(self, sid: str, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        if sid not in self.studies:
            return 404, None, {}
        return 200, self._study(self.studies[sid]), {}

    def update_study(self, sid: str, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        study = self.studies[sid]
        places = body.get("total_available_places")
        if (
            places is not None
            and study["status"] != "UNPUBLISHED"
            and places < study["total_available_places"]
        ):
            return (
                400,
                _refusal(400, "only increase"),
                {},
            )
        study.update(body)
        if study["status"] == "COMPLETED":
            study["status"] = "ACTIVE"
        self.effects[("top_up", sid)] += 1
        return 200, self._study(study), {}

    def publish_study(self, sid: str, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        study = self.studies[sid]
        if body["action"] != "PUBLISH" or study["status"] != "UNPUBLISHED":
            return (
                400,
                _refusal(400, "cannot"),
                {},
            )
        study["status"] = "ACTIVE"
        self.effects[("publish", sid)] += 1
        return 200, self._study(study), {}

    def create_test_study(self, sid: str, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        test = {**self.studies[sid], "id": new_id(), "status": "ACTIVE", "internal_name": "test"}
        self.studies[test["id"]] = test
        self.effects[("test_study", sid)] += 1
        return (
            200,
            {
                "study_id": test["id"],
                "study_url": f"https://app.prolific.test/studies/{test['id']}",
            },
            {},
        )

    def get_submissions(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        page, size = int(query.get("page", 1)), int(query.get("page_size", 20))
        mine = [s for s in self.submissions.values() if s["study_id"] == query["study"]]
        chunk = mine[(page - 1) * size : page * size]
        short = (
            "id",
            "participant_id",
            "status",
            "started_at",
            "completed_at",
            "study_code",
            "return_requested",
        )
        more = page * size < len(mine)
        return (
            200,
            {
                "results": [{**{k: s[k] for k in short}, "has_siblings": False} for s in chunk],
                "_links": {"next": {"href": f"?page={page + 1}" if more else None}},
                "meta": {"count": len(mine)},
            },
            {},
        )

    def get_submission(self, sid: str, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        s = self.submissions[sid]
        keep = (
            "id",
            "completed_at",
            "started_at",
            "status",
            "study_id",
            "return_requested",
            "bonus_payments",
        )
        return 200, {**{k: s[k] for k in keep}, "participant": s["participant_id"]}, {}

    def transition_submission(self, sid: str, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        s = self.submissions[sid]
        wanted = {"APPROVE": "APPROVED", "REJECT": "REJECTED"}.get(body["action"])
        if wanted is None:
            return 400, None, {}
        if s["status"] == wanted:  # "this endpoint is idempotent": the second request is ignored
            return 200, self._submission(s), {}
        if s["status"] != "AWAITING REVIEW":
            return (
                400,
                _refusal(400, f"submission is {s['status']}"),
                {},
            )
        if wanted == "REJECTED" and (
            len(body.get("message", "")) < 100 or "rejection_category" not in body
        ):
            return (
                400,
                _refusal(400, "message"),
                {},
            )
        s["status"] = wanted
        self.effects[("approve" if wanted == "APPROVED" else "reject", sid)] += 1
        return 200, self._submission(s), {}

    def _submission(self, s: dict[str, Any]) -> dict[str, Any]:
        return {
            "id": s["id"],
            "status": s["status"],
            "study_id": s["study_id"],
            "started_at": s["started_at"],
            "participant": s["participant_id"],
        }

    def bulk_approve_submissions(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        for sid in body.get("submission_ids", []):
            s = self.submissions.get(sid)
            if s is not None and s["status"] == "AWAITING REVIEW":
                s["status"] = "APPROVED"
                self.effects[("approve", sid)] += 1
        return 200, "Bulk approve in progress", {}

    def request_submission_return(
        self, sid: str, *, body: Any, query: Any
    ) -> tuple[int, Any, dict]:
        s = self.submissions[sid]
        s["return_requested"] = "2026-12-01T11:00:00Z"
        self.effects[("return", sid)] += 1
        return (
            200,
            {
                "id": sid,
                "status": s["status"],
                "participant": s["participant_id"],
                "return_requested": s["return_requested"],
            },
            {},
        )

    def create_bonus_payments(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        lines = {}
        for line in body["csv_bonuses"].splitlines():
            pid, _, amount = line.partition(",")
            taken = any(
                s["participant_id"] == pid and s["study_id"] == body["study_id"]
                for s in self.submissions.values()
            )
            if not taken:
                return (
                    400,
                    _refusal(400, f"{pid} did not take part"),
                    {},
                )
            lines[pid] = int(Decimal(amount) * 100)
        batch = {"id": new_id(), "study": body["study_id"], "lines": lines}
        self.batches[batch["id"]] = batch
        amount = sum(lines.values())
        fees = round(amount * 0.33)
        self.effects[("bonus", batch["id"])] += 1
        return (
            201,
            {
                "id": batch["id"],
                "study": batch["study"],
                "amount": amount,
                "fees": fees,
                "vat": round(fees * 0.2),
                "total_amount": amount + fees + round(fees * 0.2),
            },
            {},
        )

    def pay_bonus_payments(self, bid: str, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        batch = self.batches[bid]
        for pid, cents in batch["lines"].items():  # not idempotent: a second request pays again
            for s in self.submissions.values():
                if s["participant_id"] == pid and s["study_id"] == batch["study"]:
                    s["bonus_payments"].append(cents)
                    break
        self.effects[("pay", bid)] += 1
        return 202, "Bonus payments queued", {}

    def get_event_types(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        return (
            200,
            {
                "results": [
                    {"event_type": t} for t in ("study.status.change", "submission.status.change")
                ]
            },
            {},
        )

    def get_secrets(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        return (
            200,
            {
                "results": [
                    {"id": "s1", "value": self.secret, "workspace_id": query["workspace_id"]}
                ]
            },
            {},
        )

    def create_secret(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        self.secret = "whsec-" + new_id()
        return 201, {"id": "s1", "value": self.secret, "workspace_id": body["workspace_id"]}, {}

    def get_subscriptions(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        return 200, {"results": list(self.subscriptions.values())}, {}

    def create_subscription(self, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        sub = {**body, "id": new_id(), "is_enabled": False}
        self.subscriptions[sub["id"]] = sub
        return 201, {"results": [sub]}, {"X-Hook-Secret": "confirm-" + sub["id"]}

    def get_subscription(self, sub: str, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        return 200, self.subscriptions[sub], {}

    def confirm_subscription(self, sub: str, *, body: Any, query: Any) -> tuple[int, Any, dict]:
        if body.get("secret") != "confirm-" + sub:
            return 400, None, {}
        self.subscriptions[sub]["is_enabled"] = True
        return 200, self.subscriptions[sub], {}

    # -- webhooks ---------------------------------------------------------------------------

    def event(
        self,
        event_type: str,
        resource_id: str,
        status: str,
        *,
        participant_id: str | None = None,
        event_id: str | None = None,
        sent_at: float | None = None,
        secret: str | None = None,
    ) -> tuple[dict[str, str], bytes]:
        """The headers and body of a signed delivery, as Prolific's guide describes them."""
        payload: dict[str, Any] = {
            "resource_id": resource_id,
            "event_type": event_type,
            "status": status,
        }
        if participant_id is not None:
            payload["participant_id"] = participant_id
        body = json.dumps(payload).encode()
        stamp = str(int(time.time()))
        headers = {
            "Content-Type": "application/json",
            "X-Event-ID": event_id or new_id(),
            "X-Timestamp": str(sent_at if sent_at is not None else time.time()),
            "X-Prolific-Request-Timestamp": stamp,
            "X-Prolific-Request-Signature": sign(
                secret if secret is not None else self.secret, stamp, body
            ),
        }
        return headers, body


@contextmanager
def running(fake: FakeProlific) -> Iterator[str]:
    """Serve ``fake`` on a free loopback port; yields its base URL."""
    with serve(fake) as base:
        yield base
