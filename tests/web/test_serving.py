"""gunicorn's settings: timeouts, request limits, and an access log without identifying values."""

import datetime as dt
import subprocess
import sys
import time
import urllib.request
from pathlib import Path
from types import SimpleNamespace

from gunicorn.config import Config

from app.web.serving import (
    ACCESS_LOG_FORMAT,
    PrivateAccessLogger,
    proxy_warning,
    record_route,
    settings,
)

ROOT = Path(__file__).resolve().parents[2]


def _line(environ: dict) -> str:
    cfg = Config()
    cfg.set("access_log_format", ACCESS_LOG_FORMAT)
    cfg.set("accesslog", "-")
    logger = PrivateAccessLogger(cfg)
    resp = SimpleNamespace(status="200 OK", sent=512, headers=[("Set-Cookie", "fp-1=tok")])
    req = SimpleNamespace(headers=[("COOKIE", "fp-1=secret-token"), ("REFERER", "x")])
    atoms = logger.atoms(resp, req, environ, dt.timedelta(milliseconds=7))
    return logger.cfg.access_log_format % atoms


def test_the_access_line_holds_the_route_not_the_token_query_or_address():
    token, pid = "tok-Zq81xVb4", "5f3c2a9e8d7b6a5f4e3d2c1b"
    environ = {
        "REQUEST_METHOD": "GET",
        "RAW_URI": f"/p/{token}/trial?PROLIFIC_PID={pid}",
        "PATH_INFO": f"/p/{token}/trial",
        "QUERY_STRING": f"PROLIFIC_PID={pid}",
        "SERVER_PROTOCOL": "HTTP/1.1",
        "REMOTE_ADDR": "203.0.113.9",
        "HTTP_REFERER": f"https://study.example/p/{token}/instructions",
        "HTTP_USER_AGENT": "Mozilla/5.0 (X11; Linux x86_64)",
    }
    record_route(environ, "/p/<token>/trial")
    line = _line(environ)
    assert '"GET /p/<token>/trial HTTP/1.1" 200 512 7ms' in line
    for secret in (token, pid, "203.0.113.9", "Mozilla", "secret-token"):
        assert secret not in line
    del environ["facepair.route"]
    assert '"GET <unmatched> HTTP/1.1"' in _line(environ)


def test_the_app_records_each_requests_route(app, client, participant, web):
    from flask import request, request_tearing_down

    from tests.support.studies import study_slug

    seen = {}

    def read(_sender, **_extra):
        seen[request.path] = request.environ.get("facepair.route")

    token = participant.join(study_slug(app, web.study()))
    with request_tearing_down.connected_to(read, app):
        client.get(f"/p/{token}/trial")
        client.get("/no/such/page")
    assert seen[f"/p/{token}/trial"] == "/p/<token>/trial"
    assert seen["/no/such/page"] == "<unmatched>"


def test_the_server_bounds_slow_and_oversized_clients():
    s = settings("127.0.0.1", 5000, 2)
    assert s["timeout"] == 30 and s["keepalive"] == 5 and s["graceful_timeout"] == 30
    assert s["limit_request_line"] == 4094 and s["limit_request_fields"] == 100
    assert s["logger_class"] == "app.web.serving.PrivateAccessLogger"
    cfg = Config()
    for key, value in s.items():
        cfg.set(key, value)  # every one is a gunicorn setting
    assert cfg.logger_class is PrivateAccessLogger


def test_no_proxy_is_warned_about_in_one_line():
    warning = proxy_warning(0)
    assert warning and "\n" not in warning and "TRUST_PROXY" in warning
    assert proxy_warning(1) is None


def test_gunicorn_runs_the_config_module_and_logs_no_token(tmp_path):
    """The container's command line (Dockerfile): gunicorn -c python:app.web.serving."""
    port = 5000 + (hash(str(tmp_path)) % 2000) + 1000
    log = tmp_path / "access.log"
    env = {
        "SECRET_KEY": "k3Q!x9#Lm2@vR7$tP4&wZ8*cN6^bH1%e",
        "FACEPAIR_INSTANCE": str(tmp_path / "instance"),
        "PATH": str(Path(sys.executable).parent) + ":/usr/bin:/bin",
    }
    errors = (tmp_path / "error.log").open("wb")
    server = subprocess.Popen(
        [
            str(Path(sys.executable).parent / "gunicorn"),
            "-c",
            "python:app.web.serving",
            "--bind",
            f"127.0.0.1:{port}",
            "--workers",
            "1",
            "--access-logfile",
            str(log),
            "app.web:create_app()",
        ],
        cwd=ROOT,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=errors,
    )
    try:
        url = f"http://127.0.0.1:{port}/p/tok-secret-123/trial?PROLIFIC_PID=pid-secret"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                urllib.request.urlopen(url, timeout=2).close()
                break
            except urllib.error.HTTPError as answered:  # 404: no such participant
                answered.close()
                break
            except OSError:
                time.sleep(0.3)
        time.sleep(0.5)
    finally:
        server.terminate()
        server.wait(10)
        errors.close()
    text = log.read_text()
    assert "/p/<token>/trial" in text, (tmp_path / "error.log").read_text()[-2000:]
    assert "tok-secret" not in text and "pid-secret" not in text and "127.0.0.1" not in text


def test_two_serves_on_one_host_share_no_control_socket(tmp_path):
    """gunicorn 25.1+ opened its control socket at ~/.gunicorn/gunicorn.ctl (or under
    $XDG_RUNTIME_DIR) for every serve of a user: the second took the first one's, and the
    first to stop removed it. facepair serve opens none."""
    import secrets

    from tests.support.served import facepair_serve, serve_env, served_socket_paths

    run = tmp_path / "run"
    run.mkdir(mode=0o700)
    envs = []
    for name in ("one", "two"):
        env = serve_env(
            tmp_path / name,
            DATABASE_URL=f"sqlite:///{tmp_path / name / 'facepair.sqlite'}",
            SECRET_KEY=secrets.token_hex(32),
        )
        env.update(HOME=str(tmp_path / "home"), XDG_RUNTIME_DIR=str(run))
        envs.append(env)
    (tmp_path / "home").mkdir()
    with (
        facepair_serve(envs[0], workers=1, log=tmp_path / "one.log"),
        facepair_serve(envs[1], workers=1, log=tmp_path / "two.log"),
    ):
        sockets = served_socket_paths(envs[0])
    logs = (tmp_path / "one.log").read_text() + (tmp_path / "two.log").read_text()
    assert sockets == [] and "Control socket" not in logs, (sockets, logs[-2000:])
    assert settings("127.0.0.1", 5000, 1)["control_socket_disable"] is True
