"""How a study's media (clips, audio, tracks, reports) reach the browser and other machines.

``MEDIA_BACKEND`` chooses who sends the bytes once a view has checked that the asker may have
them (the check is the view's and the same for every backend):

* ``local`` (default): Flask streams the file from ``MEDIA_ROOT`` (range requests included);
  nothing else is needed, as in the demo and the tests;
* ``accel``: the view answers with an empty body and ``X-Accel-Redirect:
  MEDIA_ACCEL_PREFIX/study-<id>/<file>``; nginx serves the file from an ``internal`` location
  aliasing ``MEDIA_ROOT`` (``deploy/nginx.conf``), so a slow download never holds a Python
  worker, and the internal location cannot be asked for from outside;
* ``s3``: the files live in an S3-compatible bucket (``MEDIA_URL = "s3://bucket/prefix"``,
  ``MEDIA_S3_ENDPOINT`` for MinIO, ``MEDIA_S3_PUBLIC_ENDPOINT`` where browsers reach it;
  credentials from the environment only, as boto3 reads them). The view redirects (302) to
  a pre-signed GET URL valid for ``MEDIA_URL_TTL`` seconds, issued only after the check, so
  a participant cannot make one for a clip outside their schedule. Jobs :func:`publish` what
  they write and :func:`fetch` what they read, so a worker on another machine needs only
  the database, Redis and the bucket.
"""

from __future__ import annotations

import mimetypes
import posixpath
import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import quote

from flask import abort, current_app, redirect, render_template, send_file

from app.errors import InputError
from app.web.infra.storage import media_dir, media_file

if TYPE_CHECKING:
    from flask import Flask, Response

    from app.web.models import Study

BACKENDS = ("local", "accel", "s3")
#: The settings and their defaults (app.create_app applies them; the environment overrides).
DEFAULTS: dict[str, Any] = {
    "MEDIA_BACKEND": "local",
    # nginx's internal location (deploy/nginx.conf) whose alias is MEDIA_ROOT.
    "MEDIA_ACCEL_PREFIX": "/_protected",
    # "s3://bucket/prefix": where the files live with MEDIA_BACKEND = "s3".
    "MEDIA_URL": None,
    # An S3-compatible server other than AWS, as this machine reaches it (MinIO:
    # "http://minio:9000").
    "MEDIA_S3_ENDPOINT": None,
    # The same server as browsers reach it, which pre-signed URLs name (default: the above;
    # docker-compose's MinIO is reached through the front proxy: "https://study.example.org").
    "MEDIA_S3_PUBLIC_ENDPOINT": None,
    "MEDIA_S3_REGION": None,
    # Seconds a pre-signed URL stays valid: long enough to start a clip, short enough that a
    # copied link dies soon. Browsers keep what they fetched (Cache-Control below).
    "MEDIA_URL_TTL": 300,
}
_clients: dict[tuple[str | None, str | None], Any] = {}


class MediaStoreError(RuntimeError):
    """The bucket could not be reached or refused the request (``s3``): the job fails, and a
    web request answers 503, with this one line."""


@contextmanager
def _store(action: str) -> Iterator[None]:
    """Turn the client's errors into a :class:`MediaStoreError` naming the setting."""
    from botocore.exceptions import BotoCoreError, ClientError

    try:
        yield
    except (BotoCoreError, ClientError) as exc:
        where = current_app.config.get("MEDIA_S3_ENDPOINT") or current_app.config["MEDIA_URL"]
        raise MediaStoreError(
            f"the media store (MEDIA_URL, {where}) could not {action}: {str(exc).splitlines()[0]}"
        ) from None


def init_media(app: Flask) -> None:
    """Check the settings and answer a request the bucket failed with 503 and one line."""
    check_media_settings(app)

    def unavailable(exc: MediaStoreError):  # type: ignore[no-untyped-def]

        current_app.logger.warning("%s", exc)
        return render_template("error.html", message=str(exc), status=503), 503

    app.register_error_handler(MediaStoreError, unavailable)


def check_media_settings(app: Flask) -> None:
    """Refuse a backend that cannot work, naming the setting (called by the factory)."""
    backend = app.config["MEDIA_BACKEND"]
    if backend not in BACKENDS:
        raise InputError(
            f"expected one of {', '.join(BACKENDS)}, got {backend!r}", field="MEDIA_BACKEND"
        )
    try:
        ttl = int(app.config["MEDIA_URL_TTL"])
    except (TypeError, ValueError):
        ttl = 0
    if not 1 <= ttl <= 7 * 86400:  # S3 signs for a week at most
        raise InputError("expected seconds between 1 and 604800", field="MEDIA_URL_TTL")
    app.config["MEDIA_URL_TTL"] = ttl
    if backend == "s3":
        bucket_and_prefix(app.config.get("MEDIA_URL"))
    prefix = app.config["MEDIA_ACCEL_PREFIX"]
    if backend == "accel" and not (prefix.startswith("/") and prefix.strip("/")):
        raise InputError("expected a path such as /_protected", field="MEDIA_ACCEL_PREFIX")


def bucket_and_prefix(url: str | None) -> tuple[str, str]:
    """``("bucket", "prefix/")`` of a ``MEDIA_URL`` such as ``s3://facepair/media``.

    >>> bucket_and_prefix("s3://facepair/media")
    ('facepair', 'media/')
    """
    if not url or not url.startswith("s3://") or not url[5:].split("/", 1)[0]:
        raise InputError(f"expected s3://bucket[/prefix], got {url!r}", field="MEDIA_URL")
    bucket, _, prefix = url[5:].partition("/")
    prefix = prefix.strip("/")
    return bucket, f"{prefix}/" if prefix else ""


def object_key(study: Study, rel: str) -> str:
    """The bucket key of the study's file ``rel`` (refusing anything outside its folder)."""
    clean = posixpath.normpath(rel)
    if rel.startswith("/") or clean.startswith("..") or clean in (".", ""):
        raise ValueError(f"{rel}: outside the study's media folder")
    _, prefix = bucket_and_prefix(current_app.config.get("MEDIA_URL"))
    return f"{prefix}study-{study.id}/{clean}"


def s3_client(*, public: bool = False) -> Any:
    """A boto3 S3 client for ``MEDIA_S3_ENDPOINT`` (``public``: the endpoint browsers reach,
    for signing URLs); credentials come from the environment (AWS_ACCESS_KEY_ID, ...)."""
    endpoint = current_app.config.get("MEDIA_S3_ENDPOINT") or None
    if public:
        endpoint = current_app.config.get("MEDIA_S3_PUBLIC_ENDPOINT") or endpoint
    region = current_app.config.get("MEDIA_S3_REGION") or None
    key = (endpoint, region)
    if key not in _clients:
        import boto3
        from botocore.config import Config

        # Path-style addressing: MinIO and other self-hosted stores serve no bucket subdomains.
        # Short connect timeout and few retries: a store that is away fails the job in
        # seconds, with a reason, instead of holding a worker for minutes.
        _clients[key] = boto3.client(
            "s3",
            endpoint_url=endpoint,
            region_name=region,
            config=Config(
                signature_version="s3v4",
                s3={"addressing_style": "path"},
                connect_timeout=5,
                read_timeout=60,
                retries={"max_attempts": 3},
            ),
        )
    return _clients[key]


def _backend() -> str:
    return str(current_app.config.get("MEDIA_BACKEND") or "local")


def media_response(
    study: Study,
    rel: str | None,
    *,
    mimetype: str | None = None,
    cache_seconds: int = 0,
    headers: dict[str, str] | None = None,
    download_name: str | None = None,
) -> Response:
    """Answer with the study's file ``rel`` through the configured backend; the caller has
    already checked that the asker may have it. 404 when there is no such file.

    ``cache_seconds`` is how long the browser may keep the bytes (``private``: never a shared
    cache); ``headers`` go on the answer that carries the bytes (the local and accel ones).
    ``download_name`` is the file name the browser is told (``Content-Disposition: inline``,
    on every backend); without it the stored name is told, which a participant's clip must
    never be (docs/reference/web.md, "Blinding").
    """
    if not rel:
        abort(404)
    backend = _backend()
    if backend == "s3":
        try:
            key = object_key(study, rel)
        except ValueError:
            abort(404)
        bucket, _ = bucket_and_prefix(current_app.config.get("MEDIA_URL"))
        params = {"Bucket": bucket, "Key": key}
        if mimetype:
            params["ResponseContentType"] = mimetype
        if cache_seconds:
            params["ResponseCacheControl"] = f"private, max-age={cache_seconds}"
        if download_name:
            params["ResponseContentDisposition"] = _inline(download_name)
        url = s3_client(public=True).generate_presigned_url(
            "get_object", Params=params, ExpiresIn=int(current_app.config["MEDIA_URL_TTL"])
        )
        response = redirect(url, 302)
        # The redirect itself must not outlive its signature in any cache.
        response.headers["Cache-Control"] = "no-store"
        return response
    try:
        path = media_file(study, rel)
    except ValueError:
        abort(404)
    if not path.is_file():
        abort(404)
    if backend == "accel":
        response = current_app.response_class(b"", mimetype=mimetype or _guess_type(path))
        root = Path(current_app.config["MEDIA_ROOT"]).resolve()
        prefix = current_app.config["MEDIA_ACCEL_PREFIX"].rstrip("/")
        response.headers["X-Accel-Redirect"] = (
            f"{prefix}/{quote(path.relative_to(root).as_posix())}"
        )
        if download_name:
            # nginx passes the upstream's Content-Disposition on with the file it serves.
            response.headers["Content-Disposition"] = _inline(download_name)
    else:
        # Range requests (conditional) let the browser seek and replay without refetching.
        response = send_file(
            path,
            mimetype=mimetype,
            conditional=True,
            max_age=cache_seconds,
            download_name=download_name,
        )
    response.headers["Cache-Control"] = (
        f"private, max-age={cache_seconds}" if cache_seconds else "no-cache"
    )
    response.headers.update(headers or {})
    return response


def _inline(name: str) -> str:
    """``inline; filename="name"`` for a plain ASCII file name (the callers' names are)."""
    if not re.fullmatch(r"[A-Za-z0-9._-]{1,80}", name):
        raise ValueError(f"{name!r}: not a plain file name")
    return f'inline; filename="{name}"'


def _guess_type(path: Path) -> str:

    return mimetypes.guess_type(path.name)[0] or "application/octet-stream"


def publish(study: Study, rel: str) -> None:
    """Copy the study's local file ``rel`` to the bucket (``s3`` only; a no-op otherwise):
    called after a job or an upload writes it, so every machine and the browser can have it."""
    if _backend() != "s3":
        return
    bucket, _ = bucket_and_prefix(current_app.config.get("MEDIA_URL"))
    path = media_file(study, rel)
    with _store(f"take {rel}"):
        s3_client().upload_file(
            str(path), bucket, object_key(study, rel), ExtraArgs={"ContentType": _guess_type(path)}
        )


def publish_folder(study: Study, folder: str) -> int:
    """:func:`publish` every file under the study's ``folder``; returns how many."""
    if _backend() != "s3":
        return 0
    root = media_dir(study)
    files = sorted(p for p in (root / folder).rglob("*") if p.is_file())
    for path in files:
        publish(study, path.relative_to(root).as_posix())
    return len(files)


def forget(study: Study, folder: str = "") -> int:
    """Delete the study's files under ``folder`` (all of them by default) from the bucket
    (``s3`` only): a deleted study or participant leaves no copy there. Returns how many."""
    if _backend() != "s3":
        return 0
    bucket, prefix = bucket_and_prefix(current_app.config.get("MEDIA_URL"))
    under = f"{object_key(study, folder)}/" if folder else f"{prefix}study-{study.id}/"
    client = s3_client()
    removed = 0
    with _store(f"delete {under}"):
        for page in client.get_paginator("list_objects_v2").paginate(Bucket=bucket, Prefix=under):
            keys = [{"Key": found["Key"]} for found in page.get("Contents", [])]
            if keys:  # at most 1,000 a page, as delete_objects takes
                client.delete_objects(Bucket=bucket, Delete={"Objects": keys, "Quiet": True})
                removed += len(keys)
    return removed


def stored(study: Study, rel: str) -> bool:
    """Whether the study's file ``rel`` is where the backend serves it from (``s3``: a path
    is recorded only after its upload, so the record is the answer)."""
    if _backend() == "s3":
        return True
    try:
        return media_file(study, rel).is_file()
    except ValueError:
        return False


def fetch(study: Study, rel: str) -> Path:
    """The local path of the study's file ``rel``, downloaded from the bucket first when this
    machine has no copy (``s3``: a worker elsewhere reading what another machine wrote)."""
    path = media_file(study, rel)
    if _backend() == "s3" and not path.is_file():
        bucket, _ = bucket_and_prefix(current_app.config.get("MEDIA_URL"))
        path.parent.mkdir(parents=True, exist_ok=True)
        part = path.with_name(path.name + ".part")
        with _store(f"give {rel}"):
            s3_client().download_file(bucket, object_key(study, rel), str(part))
        part.replace(path)
    return path
