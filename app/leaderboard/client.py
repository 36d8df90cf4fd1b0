"""A small HTTP client of the platform (standard library only): what ``facepair leaderboard
submit --url`` sends a server, and what the demo's submitters and simulated participants use
to go through the real pages and API.

>>> encode_multipart({"system": "x"}, [])[0][:2]
b'--'
"""

from __future__ import annotations

import http.cookiejar
import json
import mimetypes
import re
import secrets
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

CSRF = re.compile(r'name="csrf_token"[^>]*value="([^"]+)"')


@dataclass(frozen=True)
class Answer:
    """A response: status, headers (lower-case names) and body text."""

    status: int
    headers: Mapping[str, str]
    text: str

    def json(self) -> Any:
        return json.loads(self.text)


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *args: Any, **kwargs: Any) -> None:
        return None


def encode_multipart(
    fields: Mapping[str, str], files: Sequence[tuple[str, Path]]
) -> tuple[bytes, str]:
    """A ``multipart/form-data`` body of ``fields`` and ``files`` ((form name, path)); returns
    the body and its content type."""
    boundary = "facepair-" + secrets.token_hex(12)
    parts: list[bytes] = []
    for name, value in fields.items():
        parts.append(
            f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"\r\n\r\n'.encode()
            + value.encode("utf-8")
            + b"\r\n"
        )
    for name, path in files:
        kind = mimetypes.guess_type(path.name)[0] or "application/octet-stream"
        parts.append(
            (
                f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"; '
                f'filename="{path.name}"\r\nContent-Type: {kind}\r\n\r\n'
            ).encode()
            + path.read_bytes()
            + b"\r\n"
        )
    parts.append(f"--{boundary}--\r\n".encode())
    return b"".join(parts), f"multipart/form-data; boundary={boundary}"


class Client:
    """One browser-like client of ``base`` (its own cookies; redirects not followed)."""

    def __init__(self, base: str, *, timeout: float = 60.0) -> None:
        self.base = base.rstrip("/")
        self.timeout = timeout
        self.cookies = http.cookiejar.CookieJar()
        self.opener = urllib.request.build_opener(
            urllib.request.HTTPCookieProcessor(self.cookies), _NoRedirect()
        )

    def url(self, path: str) -> str:
        return path if path.startswith("http") else self.base + path

    def request(
        self, method: str, path: str, body: bytes | None = None, content_type: str | None = None
    ) -> Answer:
        headers = {"Content-Type": content_type} if content_type else {}
        req = urllib.request.Request(self.url(path), data=body, method=method, headers=headers)
        try:
            with self.opener.open(req, timeout=self.timeout) as response:
                return Answer(
                    response.status,
                    {k.lower(): v for k, v in response.headers.items()},
                    response.read().decode("utf-8", "replace"),
                )
        except urllib.error.HTTPError as exc:
            return Answer(
                exc.code,
                {k.lower(): v for k, v in exc.headers.items()},
                exc.read().decode("utf-8", "replace"),
            )

    def get(self, path: str) -> Answer:
        return self.request("GET", path)

    def post_form(self, path: str, fields: Mapping[str, str]) -> Answer:
        body = urllib.parse.urlencode(fields).encode()
        return self.request("POST", path, body, "application/x-www-form-urlencoded")

    def post_json(self, path: str, payload: Mapping[str, Any]) -> Answer:
        return self.request("POST", path, json.dumps(payload).encode(), "application/json")

    def post_files(
        self, path: str, fields: Mapping[str, str], files: Sequence[tuple[str, Path]]
    ) -> Answer:
        body, kind = encode_multipart(fields, files)
        return self.request("POST", path, body, kind)

    def csrf(self, path: str) -> str:
        """The CSRF token of the form on ``path``."""
        found = CSRF.search(self.get(path).text)
        if found is None:
            raise RuntimeError(f"no form on {path}")
        return found.group(1)
