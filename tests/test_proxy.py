"""A real nginx (deploy/nginx.conf) in front of the test server with MEDIA_BACKEND=accel: the
participant's clip arrives through X-Accel-Redirect, whole and by range; another
participant's clip and the internal location itself are refused from outside."""

import re
import shutil
import socket
import subprocess
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study, Trial
from tests.conftest import ParticipantActions
from tests.proxy import nginx_conf

pytestmark = pytest.mark.skipif(
    shutil.which("nginx") is None, reason="nginx is not installed (make test installs it)"
)


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture
def proxy(live_server, tmp_path):
    """nginx on a free port in front of ``live_server``; yields its base URL."""
    live_server.app.config["MEDIA_BACKEND"] = "accel"
    port = _free_port()
    folder = tmp_path / "nginx"
    conf = nginx_conf(
        folder, upstream=live_server.url.split("//")[1], media=tmp_path / "media", port=port
    )
    process = subprocess.Popen(
        ["nginx", "-p", str(folder), "-c", str(conf), "-g", "daemon off;"], stderr=subprocess.PIPE
    )
    try:
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                break
            except OSError:
                assert process.poll() is None, process.stderr.read().decode()
                time.sleep(0.05)
        yield f"http://127.0.0.1:{port}"
    finally:
        process.terminate()
        process.wait(timeout=10)
        process.stderr.close()


def _get(url: str, **headers: str) -> tuple[int, dict[str, str], bytes]:
    request = urllib.request.Request(url, headers=headers)
    try:
        with urllib.request.urlopen(request, timeout=10) as answer:
            return answer.status, dict(answer.headers), answer.read()
    except urllib.error.HTTPError as refused:
        with refused:
            return refused.code, dict(refused.headers), refused.read()


def _trials(app, token: str) -> list[int]:
    with app.app_context():
        return list(
            db.session.scalars(
                sa.select(Trial.id)
                .join(Participant)
                .where(Participant.token == token, Trial.stimulus_id.is_not(None))
            )
        )


def test_nginx_delivers_the_checked_clip_and_refuses_the_rest(live_server, proxy):
    app = live_server.app
    study_id = live_server.study()
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    me, other = (ParticipantActions(app.test_client(), app) for _ in range(2))
    me.join(slug)
    other.join(slug)
    mine, theirs = _trials(app, me.token), _trials(app, other.token)
    videos = Path(app.config["MEDIA_ROOT"]) / f"study-{study_id}" / "videos"
    clip = next(videos.iterdir())
    expected = clip.read_bytes()

    status, headers, body = _get(f"{proxy}/p/{me.token}/video/{mine[0]}")
    assert status == 200 and body == expected
    assert headers["Content-Type"] == "video/mp4"
    assert "X-Accel-Redirect" not in headers  # nginx acted on it, the browser never sees it
    assert headers["Cache-Control"].startswith("private")
    # The name the browser is told is the pair's place, never the stored file's (blinding).
    assert re.fullmatch(
        r'inline; filename="(pair-\d\d|practice)\.mp4"', headers["Content-Disposition"]
    )

    status, headers, body = _get(f"{proxy}/p/{me.token}/video/{mine[0]}", Range="bytes=0-99")
    assert status == 206 and body == expected[:100]

    status, headers, _ = _get(f"{proxy}/p/{me.token}/video/{theirs[0]}")
    assert status == 404 and "X-Accel-Redirect" not in headers
    status, _, body = _get(f"{proxy}/_protected/study-{study_id}/videos/{clip.name}")
    assert status == 404 and body != expected


def test_nginx_logs_no_token_nor_prolific_id(live_server, proxy, tmp_path):
    app = live_server.app
    study_id = live_server.study()
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    me = ParticipantActions(app.test_client(), app)
    me.join(slug)
    pid = "5f3c2a9e8d7b6a5f4e3d2c1b"
    _get(f"{proxy}/s/{slug}?PROLIFIC_PID={pid}&SESSION_ID=sess-secret")
    _get(f"{proxy}/p/{me.token}/trial")
    _get(f"{proxy}/p/{me.token}/video/{_trials(app, me.token)[0]}")
    _get(f"{proxy}/api/v1/participants/{me.token}/progress")
    _get(f"{proxy}/experimenter/pilot/{me.token}")
    time.sleep(0.3)  # nginx writes its log line after the answer
    log = (tmp_path / "nginx" / "access.log").read_text()
    assert '"GET /p/<token>/trial"' in log and '"GET /p/<token>/video/' in log
    assert '"GET /api/v1/participants/<token>/progress"' in log
    assert f'"GET /s/{slug}"' in log
    for secret in (me.token, pid, "sess-secret", "127.0.0.1"):
        assert secret not in log, log


def test_nginx_refuses_a_consent_flood_from_one_address(live_server, proxy):
    """limit_req: 10 consent posts a minute and a burst of 10 from one address; then 429
    from nginx, before the app. GETs of the study link are not counted."""
    app = live_server.app
    app.config["CONSENT_LIMIT_PER_ADDRESS"] = ""  # the app's own limit out of the way
    app.config["CONSENT_LIMIT_PER_STUDY"] = ""
    study_id = live_server.study()
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    for _ in range(25):
        assert _get(f"{proxy}/s/{slug}")[0] == 200
    codes = []
    for _ in range(25):
        request = urllib.request.Request(f"{proxy}/s/{slug}", data=b"agree=1", method="POST")
        try:
            with urllib.request.urlopen(request, timeout=10) as answer:
                codes.append(answer.status)
        except urllib.error.HTTPError as refused:
            with refused:
                codes.append(refused.code)
    # the app refuses a form without its CSRF token (400); nginx refuses the flood (429)
    assert codes.count(429) >= 10 and 429 not in codes[:11], codes


def test_nginx_logs_no_address_nor_prolific_id_of_a_refused_consent(live_server, proxy, tmp_path):
    """nginx's error log wrote every refused consent as "limiting requests, ... client:
    127.0.0.1, ... request: "POST /s/<slug>?PROLIFIC_PID=...&SESSION_ID=..."": its format
    cannot be changed, so deploy/nginx.conf writes no line about a request to it."""
    app = live_server.app
    app.config["CONSENT_LIMIT_PER_ADDRESS"] = ""
    app.config["CONSENT_LIMIT_PER_STUDY"] = ""
    study_id = live_server.study()
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    pid, session_id = "5f3c2a9e8d7b6a5f4e3d2c1b", "sess-6c1f0e9d"
    codes = []
    for _ in range(25):
        request = urllib.request.Request(
            f"{proxy}/s/{slug}?PROLIFIC_PID={pid}&SESSION_ID={session_id}",
            data=b"agree=1",
            method="POST",
        )
        try:
            with urllib.request.urlopen(request, timeout=10) as answer:
                codes.append(answer.status)
        except urllib.error.HTTPError as refused:
            with refused:
                codes.append(refused.code)
    assert 429 in codes, codes  # nginx refused some: the lines the error log used to keep
    _get(f"{proxy}/p/no-such-token-4f2a/video/1?PROLIFIC_PID={pid}")  # the app's 404
    time.sleep(0.3)
    folder = tmp_path / "nginx"
    for name in ("error.log", "access.log"):
        log = (folder / name).read_text() if (folder / name).exists() else ""
        for secret in ("127.0.0.1", pid, session_id, "PROLIFIC_PID", "no-such-token"):
            assert secret not in log, f"{name}: {log[-2000:]}"
    assert f'"POST /s/{slug}" 429' in (folder / "access.log").read_text()
