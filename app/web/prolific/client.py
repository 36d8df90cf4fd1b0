"""The one client for Prolific's API v1 (``requests``): the token, retries with back-off,
paging, timeouts and one-line errors.

- Base URL: ``PROLIFIC_API_URL`` (default :data:`DEFAULT_API_URL`, Prolific's own); paths are
  the OpenAPI document's (``/api/v1/...``). The token: ``PROLIFIC_TOKEN``, sent as
  ``Authorization: Token <token>``; read from the environment only, never logged, printed,
  stored in a row or written to an export, and sent only over HTTPS (or to loopback).
- Under pytest the client refuses any host but loopback: no test reaches the real Prolific.
- 429 (Prolific's implicit limits, "retry with exponential back-off") and, for calls that are
  safe to repeat, 5xx and timeouts are retried with exponential back-off and jitter, honouring
  ``Retry-After``. A call that is not safe to repeat (``unsafe=True``: paying a bonus batch,
  which Prolific documents as not idempotent) is never retried once it may have reached
  Prolific: a 5xx, a read timeout or a dropped connection raises :class:`InDoubt`.
- Errors are one line naming the call and Prolific's message (:class:`ProlificError`).
"""

from __future__ import annotations

import ipaddress
import logging
import os
import random
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlsplit

import requests
from requests.exceptions import ConnectionError as RequestsConnectionError
from requests.exceptions import ConnectTimeout, RequestException, Timeout
from urllib3.exceptions import NewConnectionError

from app.errors import InputError

log = logging.getLogger(__name__)

DEFAULT_API_URL = "https://api.prolific.com"
#: Seconds to connect, and to wait for an answer.
TIMEOUT = (5.0, 30.0)
ATTEMPTS = 6
#: First back-off in seconds (doubled each attempt, with jitter) and the longest wait.
BACKOFF = 1.0
MAX_WAIT = 60.0
PAGE_SIZE = 100
MAX_PAGES = 1000


class ProlificError(Exception):
    """Prolific refused a call, or could not be reached: one line naming the call."""

    def __init__(self, call: str, message: str, *, status: int | None = None) -> None:
        self.call = call
        self.status = status
        self.message = " ".join(str(message).split())[:400]
        super().__init__(f"Prolific: {call}: {self.message}")


class InDoubt(ProlificError):
    """The call may have reached Prolific (a 5xx, a read timeout, a dropped connection), and
    it is not safe to send again without reading Prolific's state first."""


class Unreachable(ProlificError):
    """Prolific could not be reached at all (refused, connect timeout): nothing was sent."""


@dataclass(frozen=True)
class Answer:
    status: int
    data: Any
    headers: Mapping[str, str]


def _loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def under_test() -> bool:
    """Whether this process runs the test suite (pytest sets PYTEST_CURRENT_TEST per test)."""
    return "PYTEST_CURRENT_TEST" in os.environ or os.environ.get("FACEPAIR_TESTING") == "1"


def check_destination(base_url: str) -> str:
    """``base_url`` without a trailing slash, or an :class:`InputError`: only HTTPS (a token
    in clear text is a token given away) unless the host is loopback, and only loopback while
    the test suite runs."""
    parts = urlsplit(base_url)
    host = parts.hostname or ""
    if parts.scheme not in ("http", "https") or not host:
        raise InputError(f"expected an http(s) URL, got {base_url!r}", field="PROLIFIC_API_URL")
    if under_test() and not _loopback(host):
        raise InputError(
            f"refusing {host}: under test the Prolific client talks to loopback only "
            "(set PROLIFIC_API_URL to the fake server)",
            field="PROLIFIC_API_URL",
        )
    if parts.scheme != "https" and not _loopback(host):
        raise InputError(
            f"refusing {base_url!r}: the token is sent over HTTPS only", field="PROLIFIC_API_URL"
        )
    return base_url.rstrip("/")


def prolific_message(data: Any, fallback: str) -> str:
    """Prolific's error as one line: ``{"error": {"title", "detail"}}`` or the bare
    ``ErrorDetail`` (a detail is a string, a list, or a field -> messages mapping)."""
    error = data.get("error", data) if isinstance(data, dict) else data
    if not isinstance(error, dict):
        return fallback if not isinstance(error, str) or not error else error
    detail = error.get("detail")
    if isinstance(detail, dict):
        detail = "; ".join(
            f"{k}: {', '.join(map(str, v)) if isinstance(v, list) else v}"
            for k, v in detail.items()
        )
    elif isinstance(detail, list):
        detail = "; ".join(map(str, detail))
    title = error.get("title")
    text = " - ".join(str(p) for p in (title, detail) if p)
    return text or fallback


class ProlificClient:
    """Calls Prolific's API v1; see the module docstring. ``sleep`` is injectable (tests)."""

    def __init__(
        self,
        base_url: str,
        token: str,
        *,
        timeout: tuple[float, float] = TIMEOUT,
        attempts: int = ATTEMPTS,
        backoff: float = BACKOFF,
        max_wait: float = MAX_WAIT,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.base_url = check_destination(base_url)
        if not token or not token.strip():
            raise InputError(
                "not set: create a token in Prolific's settings", field="PROLIFIC_TOKEN"
            )
        self._token = token.strip()
        self.timeout = timeout
        self.attempts = max(1, attempts)
        self.backoff = backoff
        self.max_wait = max_wait
        self.sleep = sleep
        self._session = requests.Session()
        self._session.trust_env = False  # no proxy from the environment sees the token

    def __repr__(self) -> str:
        return f"ProlificClient({self.base_url!r})"

    def close(self) -> None:
        self._session.close()

    def _wait(self, attempt: int, retry_after: str | None) -> float:
        wait = self.backoff * (2**attempt) * (0.5 + random.random() / 2)
        if retry_after:
            try:
                wait = max(wait, float(retry_after))
            except ValueError:
                pass
        return min(wait, self.max_wait)

    def request(
        self,
        method: str,
        path: str,
        *,
        call: str,
        json: Any = None,
        params: Mapping[str, Any] | None = None,
        unsafe: bool = False,
    ) -> Answer:
        """One call with retries; ``call`` names it in errors ("approve 60f..."). Returns the
        answer of a 2xx; raises :class:`ProlificError` (4xx), :class:`InDoubt` or
        :class:`Unreachable`."""
        name = f"{method} {path} ({call})"
        headers = {"Authorization": f"Token {self._token}", "Accept": "application/json"}
        last, retry_after = "no answer", None
        for attempt in range(self.attempts):
            if attempt:
                self.sleep(self._wait(attempt - 1, retry_after))
            retry_after = None
            try:
                response = self._session.request(
                    method,
                    self.base_url + path,
                    json=json,
                    params=params,
                    headers=headers,
                    timeout=self.timeout,
                    allow_redirects=False,
                )
            except (ConnectTimeout, RequestsConnectionError) as exc:
                reason = getattr(exc.args[0], "reason", None) if exc.args else None
                never_sent = isinstance(exc, ConnectTimeout) or isinstance(
                    reason, NewConnectionError
                )
                last = f"cannot connect ({type(reason or exc).__name__})"
                if never_sent:
                    log.info("prolific %s %s: %s (attempt %d)", method, path, last, attempt + 1)
                    continue
                if unsafe:
                    raise InDoubt(name, f"the connection dropped ({type(exc).__name__})") from None
                continue
            except Timeout:
                last = "no answer within the timeout"
                if unsafe:
                    raise InDoubt(name, last) from None
                continue
            except RequestException as exc:
                raise ProlificError(name, f"{type(exc).__name__}") from None
            log.info("prolific %s %s -> %d", method, path, response.status_code)
            data = _body(response)
            if response.status_code == 429:
                last, retry_after = "429 Too Many Requests", response.headers.get("Retry-After")
                continue
            if response.status_code >= 500:
                last = f"{response.status_code} {prolific_message(data, response.reason or '')}"
                if unsafe:
                    raise InDoubt(name, last, status=response.status_code)
                continue
            if response.status_code >= 300:
                raise ProlificError(
                    name,
                    f"{response.status_code} {prolific_message(data, response.reason or '')}",
                    status=response.status_code,
                )
            return Answer(response.status_code, data, dict(response.headers))
        if last.startswith("cannot connect"):
            raise Unreachable(name, f"{last} after {self.attempts} attempts")
        raise ProlificError(name, f"{last} after {self.attempts} attempts")

    def get(self, path: str, *, call: str, params: Mapping[str, Any] | None = None) -> Any:
        return self.request("GET", path, call=call, params=params).data

    def pages(
        self, path: str, *, call: str, params: Mapping[str, Any] | None = None
    ) -> Iterator[dict[str, Any]]:
        """Every result of a paged list (``page``, ``page_size``; Prolific's default page is
        20), following pages until one is short or ``_links.next`` is empty."""
        for page in range(1, MAX_PAGES + 1):
            data = self.get(
                path, call=call, params={**(params or {}), "page": page, "page_size": PAGE_SIZE}
            )
            results = data.get("results", []) if isinstance(data, dict) else []
            yield from (r for r in results if isinstance(r, dict))
            links = data.get("_links") if isinstance(data, dict) else None
            following = (links or {}).get("next") if isinstance(links, dict) else None
            href = following.get("href") if isinstance(following, dict) else None
            if len(results) < PAGE_SIZE or (isinstance(links, dict) and not href):
                return
        raise ProlificError(f"GET {path} ({call})", f"more than {MAX_PAGES} pages")


def _body(response: requests.Response) -> Any:
    if not response.content:
        return None
    try:
        return response.json()
    except ValueError:
        return response.text[:2000]


def setting(config: Mapping[str, Any] | None, key: str, default: float) -> float:
    """A number from the application's configuration, else the environment, else ``default``
    (the CLI builds an application of its own, so tests and deployments set either)."""
    value = (config or {}).get(key) if config is not None else None
    if value is None or value == "":
        value = os.environ.get(key, "")
    try:
        return float(value) if value != "" else default
    except (TypeError, ValueError):
        raise InputError(f"expected a number, got {value!r}", field=key) from None


def client_from_environment(config: Mapping[str, Any] | None = None) -> ProlificClient:
    """The client for this deployment: ``PROLIFIC_API_URL`` and ``PROLIFIC_TOKEN`` from the
    environment (the URL may also be an application setting); the settings
    ``PROLIFIC_BACKOFF_SECONDS`` and ``PROLIFIC_ATTEMPTS`` tune the retries. Without a token
    there is no client: Prolific's own address is used only once a token is set."""
    config = config or {}
    token = os.environ.get("PROLIFIC_TOKEN", "")
    if not token.strip():
        raise InputError("not set: create a token in Prolific's settings", field="PROLIFIC_TOKEN")
    base = os.environ.get("PROLIFIC_API_URL") or config.get("PROLIFIC_API_URL") or DEFAULT_API_URL
    backoff = setting(config, "PROLIFIC_BACKOFF_SECONDS", BACKOFF)
    attempts = int(setting(config, "PROLIFIC_ATTEMPTS", ATTEMPTS))
    return ProlificClient(base, token, backoff=backoff, attempts=attempts)
