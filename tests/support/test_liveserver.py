"""The browser tests' server closes every response, even one whose client reset the connection
while werkzeug drained the request (tests/support/liveserver.py)."""

from __future__ import annotations

import socket
import struct
import threading
import time
from urllib.parse import urlsplit

from tests.support.liveserver import serve

BODY = b"x" * 1000


class _Tracked:
    def __init__(self):
        self.closed = threading.Event()
        self.calls = 0

    def __iter__(self):
        return iter([BODY])

    def close(self):
        self.calls += 1
        self.closed.set()


def _app(responses: list[_Tracked]):
    def wsgi(environ, start_response):
        start_response("200 OK", [("Content-Length", str(len(BODY)))])
        response = _Tracked()
        responses.append(response)
        return response

    return wsgi


def _reset_after_response(base: str) -> None:
    """Read the whole response, send one more byte (werkzeug's drain then blocks reading it),
    and close with a reset (SO_LINGER 0), so the drain's read fails."""
    address = urlsplit(base)
    with socket.create_connection((address.hostname, address.port), timeout=5) as sock:
        sock.sendall(b"GET / HTTP/1.1\r\nHost: t\r\n\r\n")
        received = b""
        while not received.endswith(BODY):
            chunk = sock.recv(65536)
            assert chunk, "the server closed before the body"
            received += chunk
        sock.sendall(b"!")
        time.sleep(0.2)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))


def test_a_response_is_closed_once_when_the_client_resets_during_the_drain() -> None:
    responses: list[_Tracked] = []
    with serve(_app(responses)) as base:
        _reset_after_response(base)
        time.sleep(0.2)
        assert len(responses) == 1
        assert responses[0].closed.wait(5), "the response was never closed"
    assert responses[0].calls == 1


def test_a_response_is_closed_once_on_a_clean_request() -> None:
    from urllib.request import urlopen

    responses: list[_Tracked] = []
    with serve(_app(responses)) as base:
        with urlopen(base, timeout=5) as reply:
            assert reply.read() == BODY
        assert responses[0].closed.wait(5)
    assert responses[0].calls == 1
