"""Where a study's files live: ``MEDIA_ROOT/study-<id>/`` (audio, tracks, videos, report)."""

from __future__ import annotations

import errno
from pathlib import Path

from flask import current_app

from app.web.models import Study


def media_folder(name: str) -> Path:
    """``MEDIA_ROOT/<name>``, made if missing: a study's or a leaderboard season's folder."""
    path = Path(current_app.config["MEDIA_ROOT"]) / name
    path.mkdir(parents=True, exist_ok=True)
    return path


def within(folder: Path, rel: str, what: str) -> Path:
    """The absolute path of ``rel`` in ``folder``, refusing anything outside it (``what``
    names the folder in the message)."""
    root = folder.resolve()
    path = (root / rel).resolve()
    if root not in path.parents:
        raise ValueError(f"{rel}: outside {what}")
    return path


def media_dir(study: Study) -> Path:
    return media_folder(f"study-{study.id}")


def media_file(study: Study, rel: str) -> Path:
    """The absolute path of ``rel``, refusing anything outside the study's folder."""
    return within(media_dir(study), rel, "the study's media folder")


def disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` says the disk (or the account's quota) is full."""
    return isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT)


def disk_full_message(exc: OSError) -> str:
    where = f" writing {Path(exc.filename).name}" if exc.filename else ""
    return f"the server's disk is full{where}; free some space and try again"


def report_path(study: Study) -> Path:
    """Where the study's HTML report is written (the PDF and figures beside it)."""
    return media_dir(study) / "report" / "report.html"
