"""The start of a process that answers no web request (``app.web.standalone``): no deployment
key needed, and no database connection left open once its work is done."""

import sqlalchemy as sa

from app.web.extensions import db
from app.web.standalone import app_context, offline_app


def test_a_process_without_a_key_starts_and_ends_holding_no_connection(monkeypatch, tmp_path):
    monkeypatch.delenv("SECRET_KEY", raising=False)
    monkeypatch.delenv("DATABASE_URL", raising=False)
    monkeypatch.setenv("FACEPAIR_INSTANCE", str(tmp_path / "instance"))
    app = offline_app({"JOB_RUNNER": "inline"})
    assert app.config["REQUIRE_SECRET_KEY"] is False and app.config["JOB_RUNNER"] == "inline"
    with app_context(app) as entered:
        assert entered is app
        assert db.session.scalar(sa.text("SELECT 1")) == 1
        engine = db.engine
        assert engine.pool.checkedout() == 1
    assert engine.pool.checkedout() == 0
