"""A fake S3 bucket for the media tests: a moto server on this machine, credentials in the
environment as a deployment sets them, and a switch of a test's application to one of the media
backends (``local``, ``accel``, ``s3``), its rendered clips published where it serves them from.
The fixtures are imported by the test modules that use them (``tests/web/infra/test_media.py``,
``tests/web/participant/test_blinding.py``). Nothing here is part of the application."""

from __future__ import annotations

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.infra import media
from app.web.models import Study
from tests.support.served import free_port

#: The bucket the ``s3`` backend serves from.
BUCKET = "facepair-test"


@pytest.fixture(scope="module")
def s3_server():
    """An S3 server on this machine (moto), never the internet."""
    from moto.server import ThreadedMotoServer

    port = free_port()
    server = ThreadedMotoServer(ip_address="127.0.0.1", port=port, verbose=False)
    server.start()
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.stop()


@pytest.fixture
def s3_env(s3_server, monkeypatch):
    """Credentials as a deployment sets them: in the environment, never in the config."""
    for key, value in {
        "AWS_ACCESS_KEY_ID": "testing",
        "AWS_SECRET_ACCESS_KEY": "testing",
        "AWS_DEFAULT_REGION": "us-east-1",
    }.items():
        monkeypatch.setenv(key, value)
    media._clients.clear()
    yield s3_server
    media._clients.clear()


def use_backend(app, backend: str, request) -> None:
    """Switch ``app`` to ``backend`` and put the rendered clips where it serves them from."""
    app.config["MEDIA_BACKEND"] = backend
    if backend != "s3":
        return
    endpoint = request.getfixturevalue("s3_env")
    app.config.update(MEDIA_URL=f"s3://{BUCKET}/media", MEDIA_S3_ENDPOINT=endpoint)
    with app.app_context():
        client = media.s3_client()
        if BUCKET not in {b["Name"] for b in client.list_buckets().get("Buckets", [])}:
            client.create_bucket(Bucket=BUCKET)
        for study in db.session.scalars(sa.select(Study)):
            media.publish_folder(study, "videos")
