"""docker-compose.yml cannot run here (no Docker engine): check its structure instead."""

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent


def _compose() -> dict:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text(encoding="utf-8"))


def test_services_and_their_order():
    services = _compose()["services"]
    assert set(services) == {"postgres", "redis", "migrate", "web", "worker"}
    for name in ("postgres", "redis", "web"):
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
    from app import create_app

    app = create_app({"TESTING": True, "SQLALCHEMY_DATABASE_URI":
                      f"sqlite:///{tmp_path / 'h.sqlite'}", "MEDIA_ROOT": str(tmp_path)})
    check = " ".join(_compose()["services"]["web"]["healthcheck"]["test"])
    path = check.split("127.0.0.1:8000", 1)[1].split("'", 1)[0]
    assert app.test_client().get(path).status_code == 200
    dockerfile = (ROOT / "Dockerfile").read_text(encoding="utf-8")
    assert "0.0.0.0:8000" in dockerfile and "EXPOSE 8000" in dockerfile
