"""``facepair serve`` as a separate process (gunicorn with several workers, as deployed) and a
crowd of concurrent consents against it. Nothing here is part of the application.
"""

from __future__ import annotations

import http.cookiejar
import os
import re
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def serve_env(tmp_path: Path, **settings: str) -> dict[str, str]:
    """The environment of a served process: this interpreter's PATH, a home and an instance
    folder of its own under ``tmp_path``, and ``settings`` (``DATABASE_URL``, ``SECRET_KEY``,
    ``REDIS_URL`` ...)."""
    home = tmp_path / "home"
    home.mkdir(parents=True, exist_ok=True)
    return {
        "PATH": str(Path(sys.executable).parent) + ":/usr/bin:/bin",
        "HOME": str(home),
        "FACEPAIR_INSTANCE": str(tmp_path / "instance"),
        "PYTHONPATH": str(ROOT),
        **settings,
    }


@contextmanager
def facepair_serve(env: dict[str, str], *, workers: int, log: Path) -> Iterator[str]:
    """``python -m app serve --workers N`` on a free port; yields its base URL once it answers,
    and stops it (SIGTERM, gunicorn's graceful stop) on the way out."""
    port = free_port()
    with log.open("wb") as errors:
        server = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "app",
                "serve",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
                "--workers",
                str(workers),
            ],
            cwd=ROOT,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=errors,
        )
        try:
            base = f"http://127.0.0.1:{port}"
            deadline = time.monotonic() + 60
            while True:
                assert server.poll() is None, log.read_text()[-3000:]
                try:
                    urllib.request.urlopen(f"{base}/healthz", timeout=2).close()
                    break
                except OSError:
                    assert time.monotonic() < deadline, log.read_text()[-3000:]
                    time.sleep(0.2)
            # every worker has booted (each writes its line): a request may reach any of them
            while log.read_text().count("Booting worker") < workers:
                assert time.monotonic() < deadline, log.read_text()[-3000:]
                time.sleep(0.1)
            yield base
        finally:
            server.terminate()
            server.wait(30)


def _opener() -> urllib.request.OpenerDirector:
    class NoRedirect(urllib.request.HTTPRedirectHandler):
        def redirect_request(self, *args, **kwargs):  # type: ignore[no-untyped-def]
            return None

    jar = http.cookiejar.CookieJar()
    return urllib.request.build_opener(urllib.request.HTTPCookieProcessor(jar), NoRedirect)


def _status(opener: urllib.request.OpenerDirector, request: urllib.request.Request) -> int:
    try:
        with opener.open(request, timeout=60) as answer:
            return answer.status
    except urllib.error.HTTPError as refused:
        with refused:
            return refused.code


def consent_crowd(base: str, slug: str, count: int) -> list[int]:
    """``count`` browsers from one address open the study link (one after another: each gets
    its session and CSRF token), then all post the consent form at once. Returns the answers'
    status codes: 302 for a new participant, 429 for a refusal."""
    ready = []
    for _ in range(count):
        opener = _opener()
        with opener.open(f"{base}/s/{slug}", timeout=30) as page:
            html = page.read().decode()
        token = re.search(r'name="csrf_token"[^>]*value="([^"]+)"', html)
        assert token, html[:500]
        body = urllib.parse.urlencode({"csrf_token": token.group(1), "agree": "1"}).encode()
        ready.append((opener, body))
    start = threading.Barrier(count)
    codes: list[int] = [0] * count

    def post(index: int) -> None:
        opener, body = ready[index]
        start.wait()
        request = urllib.request.Request(f"{base}/s/{slug}", data=body, method="POST")
        codes[index] = _status(opener, request)

    threads = [threading.Thread(target=post, args=(i,)) for i in range(count)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(120)
    return codes


def served_socket_paths(env: dict[str, str]) -> list[Path]:
    """Unix sockets under the served process's home and runtime folder (where gunicorn 25.1+
    puts its control socket, ``gunicorn.ctl``, unless told otherwise)."""
    found = []
    for folder in (env.get("HOME"), env.get("XDG_RUNTIME_DIR")):
        if folder and os.path.isdir(folder):
            found += [p for p in Path(folder).rglob("*") if p.is_socket()]
    return found
