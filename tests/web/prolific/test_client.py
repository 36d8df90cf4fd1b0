"""The Prolific client: no test ever reaches the real Prolific, the token never shows,
retries on 429 and 5xx (never on a payment that may have gone through), paging, one-line
errors naming the call and Prolific's message."""

from __future__ import annotations

import logging
import socket

import pytest

from app.errors import InputError
from app.web.prolific.client import (
    DEFAULT_API_URL,
    InDoubt,
    ProlificClient,
    ProlificError,
    Unreachable,
    check_destination,
    client_from_environment,
)
from tests.support.fake_prolific import TOKEN, FakeProlific, running
from tests.web.prolific.conftest import draft


@pytest.fixture
def service():
    fake = FakeProlific()
    with running(fake) as base:
        fake.url = base  # type: ignore[attr-defined]
        yield fake


def _client(fake, **options) -> ProlificClient:
    return ProlificClient(fake.url, TOKEN, backoff=0.001, **options)


def test_the_default_client_refuses_to_run_under_test(monkeypatch):
    monkeypatch.delenv("PROLIFIC_API_URL", raising=False)
    monkeypatch.setenv("PROLIFIC_TOKEN", TOKEN)
    with pytest.raises(InputError) as refused:
        client_from_environment({})
    assert "api.prolific.com" in str(refused.value) and "loopback" in str(refused.value)
    for url in (DEFAULT_API_URL, "https://api.prolific.com/", "http://10.0.0.8:9000"):
        with pytest.raises(InputError, match="loopback"):
            check_destination(url)
    assert check_destination("http://127.0.0.1:8123/") == "http://127.0.0.1:8123"


def test_the_token_goes_only_over_https_outside_loopback(monkeypatch):
    monkeypatch.delenv("PYTEST_CURRENT_TEST")
    with pytest.raises(InputError, match="HTTPS only"):
        check_destination("http://prolific.example.org")
    assert check_destination("https://api.prolific.com") == DEFAULT_API_URL


def test_a_missing_token_is_one_line(monkeypatch, service):
    monkeypatch.setenv("PROLIFIC_API_URL", service.url)
    monkeypatch.delenv("PROLIFIC_TOKEN", raising=False)
    with pytest.raises(InputError, match="PROLIFIC_TOKEN: not set"):
        client_from_environment({})
    # without a token Prolific's own address is never even considered
    monkeypatch.delenv("PROLIFIC_API_URL")
    monkeypatch.setenv("PROLIFIC_TOKEN", "  ")
    with pytest.raises(InputError, match="PROLIFIC_TOKEN: not set"):
        client_from_environment({})


def test_the_token_is_never_logged_or_shown(service, caplog):
    caplog.set_level(logging.DEBUG)
    client = _client(service)
    assert client.get("/api/v1/users/me/", call="who am I")["id"]
    with pytest.raises(ProlificError) as refused:
        client.request(
            "POST", "/api/v1/studies/nope/transition/", call="publish", json={"action": "PUBLISH"}
        )
    shown = [str(refused.value), repr(client), caplog.text]
    assert not any(TOKEN in text for text in shown)
    assert str(refused.value).count("\n") == 0


def test_a_429_storm_is_waited_out_with_backoff(service):
    waits: list[float] = []
    client = ProlificClient(service.url, TOKEN, backoff=0.5, max_wait=4, sleep=waits.append)
    service.storm = 5
    assert client.get("/api/v1/workspaces/", call="list workspaces")["results"]
    assert len(waits) == 5 and waits == sorted(waits) or max(waits) <= 4
    assert waits[0] <= 0.5 and max(waits) <= 4
    service.storm = 50
    with pytest.raises(ProlificError, match="429 Too Many Requests after 3 attempts") as storm:
        _client(service, attempts=3).get("/api/v1/workspaces/", call="list workspaces")
    assert storm.value.status is None and not isinstance(storm.value, InDoubt)


def test_5xx_is_retried_when_safe_and_in_doubt_when_not(service):
    client = _client(service)
    service.fail_next.append(("/workspaces/$", 503))
    assert client.get("/api/v1/workspaces/", call="list workspaces")["results"]
    service.fail_next.append(("/pay/$", 500))
    with pytest.raises(InDoubt, match="500"):
        client.request("POST", "/api/v1/bulk-bonus-payments/abc/pay/", call="pay", unsafe=True)
    assert [p for m, p, _ in service.requests if p.endswith("/pay/")] == [
        "/api/v1/bulk-bonus-payments/abc/pay/"
    ]


def test_errors_name_the_call_and_prolifics_message(service):
    client = _client(service)
    made = client.request("POST", "/api/v1/studies/", call="create", json=draft()).data
    client.request(
        "POST",
        f"/api/v1/studies/{made['id']}/transition/",
        call="publish",
        json={"action": "PUBLISH"},
    )
    with pytest.raises(ProlificError) as again:
        client.request(
            "POST",
            f"/api/v1/studies/{made['id']}/transition/",
            call="publish",
            json={"action": "PUBLISH"},
        )
    path = f"/api/v1/studies/{made['id']}/transition/"
    assert str(again.value) == f"Prolific: POST {path} (publish): 400 Bad Request - cannot"
    assert again.value.status == 400


def test_paging_reads_every_submission(service):
    client = _client(service)
    study = client.request("POST", "/api/v1/studies/", call="create", json=draft()).data["id"]
    for _ in range(230):
        service.start(study)
    listed = list(client.pages("/api/v1/submissions/", call="list", params={"study": study}))
    assert len(listed) == 230 and len({s["id"] for s in listed}) == 230
    pages = [p for m, p, _ in service.requests if p == "/api/v1/submissions/"]
    assert len(pages) == 3


def test_an_unreachable_prolific_is_one_line():
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    client = ProlificClient(f"http://127.0.0.1:{port}", TOKEN, backoff=0.001, attempts=2)
    with pytest.raises(Unreachable, match="cannot connect .* after 2 attempts"):
        client.get("/api/v1/users/me/", call="who am I")
