import secrets
import subprocess
import sys

from app.web import create_app


def test_config_mapping_wins(tmp_path):
    app = create_app({"TESTING": True, "SQLALCHEMY_DATABASE_URI": f"sqlite:///{tmp_path}/x.db"})
    assert app.testing and app.config["SQLALCHEMY_DATABASE_URI"].endswith("x.db")


def test_default_database_is_sqlite_in_instance_folder(monkeypatch, tmp_path):
    monkeypatch.delenv("DATABASE_URL", raising=False)
    monkeypatch.setenv("FACEPAIR_INSTANCE", str(tmp_path / "instance"))
    app = create_app({"TESTING": True})
    assert app.instance_path == str(tmp_path / "instance")
    assert app.config["SQLALCHEMY_DATABASE_URI"].startswith("sqlite:///")
    assert app.instance_path in app.config["SQLALCHEMY_DATABASE_URI"]


def test_database_url_from_environment(monkeypatch):
    monkeypatch.setenv("DATABASE_URL", "postgresql+psycopg://postgres@127.0.0.1/test")
    monkeypatch.setenv("SECRET_KEY", secrets.token_hex(32))
    assert create_app().config["SQLALCHEMY_DATABASE_URI"].startswith("postgresql+psycopg")


def test_pure_packages_never_load_flask():
    code = (
        "import sys, app.stimuli.io, app.stimuli.speech, app.errors\n"
        "bad = [m for m in ('flask', 'flask_sqlalchemy', 'moderngl') if m in sys.modules]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
