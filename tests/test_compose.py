"""docker-compose.yml cannot run here (no Docker engine): check its structure instead, and
that deploy/nginx.conf agrees with the app (media volume, internal location, proxy headers)."""

import re
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parent.parent


def _compose() -> dict:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text(encoding="utf-8"))


def test_services_and_their_order():
    services = _compose()["services"]
    assert set(services) == {
        "postgres",
        "redis",
        "migrate",
        "web",
        "worker",
        "nginx",
        "minio",
        "minio-bucket",
    }
    for name in ("postgres", "redis", "web", "nginx", "minio"):
        assert "healthcheck" in services[name], name
    assert services["migrate"]["command"][-2:] == ["db", "upgrade"]
    assert services["migrate"]["depends_on"]["postgres"]["condition"] == "service_healthy"
    for name in ("web", "worker"):
        needs = services[name]["depends_on"]
        assert needs["migrate"]["condition"] == "service_completed_successfully"
        assert needs["redis"]["condition"] == "service_healthy"
        env = services[name]["environment"]
        assert env["DATABASE_URL"].startswith("postgresql+psycopg://")
        assert env["REDIS_URL"].startswith("redis://")


def test_the_web_health_check_hits_a_real_route(tmp_path):
    from app.web import create_app

    app = create_app(
        {
            "TESTING": True,
            "SQLALCHEMY_DATABASE_URI": f"sqlite:///{tmp_path / 'h.sqlite'}",
            "MEDIA_ROOT": str(tmp_path),
        }
    )
    check = " ".join(_compose()["services"]["web"]["healthcheck"]["test"])
    path = check.split("127.0.0.1:8000", 1)[1].split("'", 1)[0]
    assert app.test_client().get(path).status_code == 200
    dockerfile = (ROOT / "Dockerfile").read_text(encoding="utf-8")
    assert "0.0.0.0:8000" in dockerfile and "EXPOSE 8000" in dockerfile


def _nginx() -> str:
    return (ROOT / "deploy" / "nginx.conf").read_text(encoding="utf-8")


def _location(conf: str, path: str) -> str:
    found = re.search(r"location " + re.escape(path) + r" \{(.*?)\n    \}", conf, re.S)
    assert found, path
    return found.group(1)


def test_the_proxy_fronts_the_app_and_serves_the_media_volume():
    services = _compose()["services"]
    nginx, web = services["nginx"], services["web"]
    assert nginx["depends_on"]["web"]["condition"] == "service_healthy"
    assert "ports" not in web and nginx["ports"]  # the app is reached through the proxy only
    assert "/healthz" in " ".join(nginx["healthcheck"]["test"])
    env = web["environment"]
    assert env["MEDIA_BACKEND"].startswith("${MEDIA_BACKEND:-accel}")
    assert env["TRUST_PROXY"] == "1"
    conf = _nginx()
    mounts = {m.split(":")[1]: m.split(":")[0] for m in nginx["volumes"]}
    assert mounts["/etc/nginx/conf.d/default.conf"] == "./deploy/nginx.conf"
    # the internal location's alias is the volume the app writes, at the app's MEDIA_ROOT
    internal = _location(conf, env["MEDIA_ACCEL_PREFIX"] + "/")
    assert re.search(r"^\s*internal;", internal, re.M)
    alias = re.search(r"alias (\S+);", internal).group(1)
    assert alias.rstrip("/") == env["MEDIA_ROOT"]
    assert mounts[env["MEDIA_ROOT"]] == next(
        v.split(":")[0] for v in web["volumes"] if v.split(":")[1] == env["MEDIA_ROOT"]
    )
    from app.web.infra.security import REPORT_CONTENT_SECURITY_POLICY

    assert f'Content-Security-Policy "{REPORT_CONTENT_SECURITY_POLICY}" always' in internal


def test_the_proxy_sets_every_forwarded_header_the_app_trusts():
    """TRUST_PROXY=1 makes the app believe X-Forwarded-For/Proto/Host/Port/Prefix from one
    proxy: nginx must set each itself, or a client could pass its own through."""
    app_location = _location(_nginx(), "/")
    for header in (
        "X-Forwarded-For",
        "X-Forwarded-Proto",
        "X-Forwarded-Host",
        "X-Forwarded-Port",
        "X-Forwarded-Prefix",
    ):
        assert re.search(rf"proxy_set_header {header} ", app_location), header
    assert "$proxy_add_x_forwarded_for" not in app_location  # never the client's own list
    assert "client_max_body_size 200m;" in _nginx()


def test_the_minio_profile_is_optional_and_makes_the_bucket_the_app_names():
    services = _compose()["services"]
    for name in ("minio", "minio-bucket"):
        assert services[name]["profiles"] == ["s3"]
    assert all("profiles" not in services[name] for name in ("web", "worker", "nginx"))
    bucket = services["web"]["environment"]["MEDIA_URL"].split("s3://")[1].rstrip("}")
    assert f"local/{bucket}" in services["minio-bucket"]["entrypoint"][-1]
    assert services["minio-bucket"]["depends_on"]["minio"]["condition"] == "service_healthy"
    # browsers reach the bucket's path through the proxy, with the Host it was signed for
    location = _location(_nginx(), f"/{bucket}/")
    assert "proxy_set_header Host $http_host;" in location


@pytest.mark.skipif(shutil.which("nginx") is None, reason="nginx is not installed")
def test_nginx_accepts_the_configuration(tmp_path):
    from tests.proxy import nginx_conf

    conf = nginx_conf(tmp_path, upstream="127.0.0.1:9", media=tmp_path / "media", port=8089)
    checked = subprocess.run(
        ["nginx", "-t", "-p", str(tmp_path), "-c", str(conf)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert checked.returncode == 0, checked.stderr
