"""The simulated people of the fault checks (``benchmarks/chaos.py``): participants voting as
the participant page's script does, and an experimenter rendering a study from the web.

Every request goes to 127.0.0.1. A request is sent again after a network error or a 5xx,
honouring Retry-After (what ``static/pair.js`` does with a vote, and what a person does
with a page that failed), never after a 4xx; every 5xx is counted by its cause.
"""

from __future__ import annotations

import http.client
import json
import re
import secrets
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any
from urllib.parse import urlencode

if TYPE_CHECKING:
    from benchmarks.chaos import Result
    from benchmarks.chaos_services import JobWorker

FORM = {"Content-Type": "application/x-www-form-urlencoded"}


@dataclass
class Tally:
    """What every client saw, shared between threads."""

    server_errors: Counter[str] = field(default_factory=Counter)
    refused: Counter[int] = field(default_factory=Counter)
    failures: Counter[str] = field(default_factory=Counter)
    network_errors: int = 0
    resent: int = 0
    lock: threading.Lock = field(default_factory=threading.Lock)


def cause(status: int, body: bytes) -> str:
    """A 5xx answer in a few words: its JSON error, or the page's heading."""
    text = body.decode("utf-8", "replace")
    found = re.search(r'"error":\s*"([^"]*)"', text) or re.search(r"<h1>(.*?)</h1>", text, re.S)
    return f"{status} {found.group(1).strip()[:70] if found else text.strip()[:70]}"


class Browser:
    """One person's browser: a keep-alive connection, cookies, and the resend rule."""

    def __init__(self, port: int, tally: Tally, *, give_up_after: float = 180.0) -> None:
        self.port, self.tally, self.give_up_after = port, tally, give_up_after
        self.cookies: dict[str, str] = {}
        self.conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.conn.close()

    def request(
        self,
        method: str,
        path: str,
        body: bytes | None = None,
        headers: dict[str, str] | None = None,
    ) -> tuple[int, dict[str, str], bytes]:
        deadline = time.monotonic() + self.give_up_after
        attempt = 0
        while True:
            head = dict(headers or {})
            if self.cookies:
                head["Cookie"] = "; ".join(f"{k}={v}" for k, v in self.cookies.items())
            wait = min(8.0, 0.25 * 2**attempt)
            try:
                self.conn.request(method, path, body=body, headers=head)
                response = self.conn.getresponse()
                data = response.read()
            except (OSError, http.client.HTTPException):
                with self.tally.lock:
                    self.tally.network_errors += 1
                self.conn.close()
                self.conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=60)
            else:
                for name, value in response.getheaders():
                    if name.lower() == "set-cookie":
                        key, _, rest = value.partition("=")
                        self.cookies[key] = rest.split(";", 1)[0]
                if response.status < 500:
                    return response.status, {k.lower(): v for k, v in response.getheaders()}, data
                with self.tally.lock:
                    self.tally.server_errors[cause(response.status, data)] += 1
                retry_after = response.getheader("Retry-After")
                if retry_after and retry_after.isdigit():
                    wait = max(1.0, float(retry_after))
            if time.monotonic() + wait > deadline:
                raise RuntimeError(
                    f"{method} {path}: no answer below 500 after {self.give_up_after:.0f} s"
                )
            attempt += 1
            with self.tally.lock:
                self.tally.resent += 1
            time.sleep(wait)

    def csrf(self, path: str) -> str:
        status, _, page = self.request("GET", path)
        found = re.search(rb'name="csrf_token"[^>]*value="([^"]+)"', page)
        if status != 200 or found is None:
            raise RuntimeError(f"{path}: HTTP {status}, no form")
        return found.group(1).decode()

    def post_form(
        self, path: str, fields: dict[str, str], page: str | None = None
    ) -> tuple[int, dict[str, str], bytes]:
        data = {"csrf_token": self.csrf(page or path), **fields}
        return self.request("POST", path, urlencode(data).encode(), FORM)

    def login(self, email: str, password: str) -> int:
        status, _, _ = self.post_form("/experimenter/login", {"email": email, "password": password})
        return status

    def job_ids(self, study_id: int) -> set[int]:
        _, _, page = self.request("GET", f"/experimenter/studies/{study_id}")
        return {int(i) for i in re.findall(rb'data-job-url="/api/v1/jobs/(\d+)"', page)}

    def start_job(self, study_id: int, kind: str, retry_of: int | None = None) -> str:
        """Press a job button on the study page; returns the page shown afterwards."""
        base = f"/experimenter/studies/{study_id}"
        action = f"{base}/jobs/{retry_of}/retry" if retry_of else f"{base}/jobs/{kind}"
        self.post_form(action, {}, page=base)
        return self.request("GET", base)[2].decode("utf-8", "replace")

    def job(self, job_id: int) -> dict[str, Any]:
        status, _, body = self.request("GET", f"/api/v1/jobs/{job_id}")
        if status != 200:
            raise RuntimeError(f"job {job_id}: HTTP {status}")
        return json.loads(body)


class Participant(threading.Thread):
    """Consent, then trial page and vote until done; one vote in ten sent twice (a retried
    request with the same key)."""

    def __init__(
        self, port: int, slug: str, tally: Tally, think: tuple[float, float], *, delay: float = 0.0
    ) -> None:
        super().__init__(daemon=True)
        self.port, self.slug, self.tally, self.think, self.delay = port, slug, tally, think, delay
        self.acknowledged: list[tuple[int, str]] = []
        self.error: str | None = None

    def run(self) -> None:
        time.sleep(self.delay)
        try:
            with Browser(self.port, self.tally) as browser:
                self._take_part(browser)
        except Exception as exc:  # noqa: BLE001 - reported in the figures
            self.error = f"{type(exc).__name__}: {exc}"

    def _pause(self) -> None:
        low, high = self.think
        time.sleep(low + (high - low) * secrets.randbelow(1000) / 1000)

    def _take_part(self, browser: Browser) -> None:
        query = f"?PROLIFIC_PID=chaos{secrets.token_hex(6)}&STUDY_ID=chaos&SESSION_ID=s"
        status, head, _ = browser.post_form(f"/s/{self.slug}{query}", {"agree": "1"})
        if status != 302:
            raise RuntimeError(f"consent: HTTP {status}")
        token = head["location"].split("/p/")[1].split("/")[0]
        while True:
            status, head, page = browser.request("GET", f"/p/{token}/trial")
            if status == 302:
                return
            found = re.search(rb'data-trial-id="(\d+)"', page)
            if status != 200 or found is None:
                raise RuntimeError(f"trial page: HTTP {status}")
            trial = int(found.group(1))
            self._pause()
            choice = secrets.choice(["left", "right", "undecided"])
            body = json.dumps(
                {
                    "token": token,
                    "trial_id": trial,
                    "choice": choice,
                    "plays": 1,
                    "watched_to_end": True,
                    "response_ms": 1500,
                    "idempotency_key": secrets.token_hex(8),
                }
            ).encode()
            for _ in range(2 if secrets.randbelow(10) == 0 else 1):
                status, _, _ = browser.request(
                    "POST", "/api/v1/votes", body, {"Content-Type": "application/json"}
                )
                if status not in (200, 201):
                    with self.tally.lock:
                        self.tally.refused[status] += 1
                    raise RuntimeError(f"vote refused: HTTP {status}")
            self.acknowledged.append((trial, choice))


class Experimenter(threading.Thread):
    """Generates and renders a study from the web while its render job is killed: each kill
    must leave the row failed with a reason, and the retry must resume."""

    def __init__(
        self,
        port: int,
        study_id: int,
        worker: JobWorker,
        kills: tuple[str, ...],
        login: tuple[str, str],
        result: Result,
    ) -> None:
        super().__init__(daemon=True)
        self.port, self.study_id, self.worker, self.kills = port, study_id, worker, kills
        self.login, self.result = login, result
        self.browser: Browser | None = None

    def run(self) -> None:
        try:
            with Browser(self.port, Tally()) as self.browser:
                self._render()
        except Exception as exc:  # noqa: BLE001 - reported in the figures
            self.result.jobs.append(f"experimenter stopped: {type(exc).__name__}: {exc}")

    def _start(self, kind: str, retry_of: int | None = None) -> int:
        assert self.browser is not None
        before = self.browser.job_ids(self.study_id)
        for _ in range(30):  # the queue may be away (a Redis outage): press again later
            self.browser.start_job(self.study_id, kind, retry_of)
            new = self.browser.job_ids(self.study_id) - before
            if new:
                return max(new)
            time.sleep(1.0)
        raise RuntimeError(f"the {kind} job could not be started")

    def _wait(self, job_id: int, until: Any, seconds: float = 600.0) -> dict[str, Any]:
        assert self.browser is not None
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            job = self.browser.job(job_id)
            if until(job) or job["status"] in ("done", "failed"):
                return job
            time.sleep(0.3)
        raise RuntimeError(f"job {job_id} neither finished nor failed in {seconds:.0f} s")

    def _render(self) -> None:
        assert self.browser is not None
        if self.browser.login(*self.login) != 302:
            raise RuntimeError("experimenter login failed")
        job = self._wait(self._start("generate"), lambda j: False)
        self.result.jobs.append(f"generate {job['status']}: {job['message']}")
        job_id, kills, failures, reached = self._start("render"), list(self.kills), 0, 0
        while True:
            # Each kill comes two clips after the last one reached: mid-job, with work kept.
            job = self._wait(
                job_id,
                lambda j, floor=reached + 2: (
                    bool(kills) and j["status"] == "running" and j["done"] >= floor
                ),
            )
            if job["status"] == "running":
                kill = kills.pop(0)
                reached = job["done"]
                if kill == "horse":
                    # the horse of the next clip, killed as it starts (see kill_next_horse)
                    self.worker.kill_next_horse(30.0)
                    job = self._wait(job_id, lambda j: False)
                else:
                    # The machine is down for longer than the stale limit: the worker is
                    # restarted once the row has been swept. (Restarted within the limit, it
                    # would take the queued clips on and finish the row, nothing lost, and
                    # the sweep would not be exercised: worker start-up times decided which.)
                    # (A killed worker is not one that exited: the supervisor leaves it.)
                    self.worker.kill_all()
                    job = self._wait(job_id, lambda j: False)
                    self.worker.start()
                self.result.kills.append(
                    (kill, f"{job['status']} at {job['done']}/{job['total']}: {job['message']}")
                )
            elif job["status"] == "failed":  # failed by another fault: retried as well
                failures += 1
                self.result.jobs.append(f"render failed by another fault: {job['message']}")
            if job["status"] != "failed" or failures > 5:
                break
            job_id = self._start("render", retry_of=job_id)
        self.result.jobs.append(f"render {job['status']}: {job['message']}")
        self.result.resumed = (
            job["status"] == "done"
            and len(self.result.kills) == len(self.kills)
            and "kept from before" in job["message"]
        )
        if self.kills and not all(m.startswith("failed") for _, m in self.result.kills):
            self.result.resumed = False

    def sweep(self) -> None:
        """Read every job of the study, as the study page does (the sweeper runs)."""
        with Browser(self.port, Tally()) as browser:
            browser.login(*self.login)
            for job_id in browser.job_ids(self.study_id):
                browser.job(job_id)
