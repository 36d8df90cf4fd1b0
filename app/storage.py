"""Where a study's files live: ``MEDIA_ROOT/study-<id>/`` (audio, tracks, videos, report)."""

from __future__ import annotations

from pathlib import Path

from flask import current_app

from app.models import Study


def media_dir(study: Study) -> Path:
    path = Path(current_app.config["MEDIA_ROOT"]) / f"study-{study.id}"
    path.mkdir(parents=True, exist_ok=True)
    return path


def media_file(study: Study, rel: str) -> Path:
    """The absolute path of ``rel``, refusing anything outside the study's folder."""
    root = media_dir(study).resolve()
    path = (root / rel).resolve()
    if root not in path.parents:
        raise ValueError(f"{rel}: outside the study's media folder")
    return path
