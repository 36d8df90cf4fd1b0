"""Files uploaded for a study that does not exist yet, kept across a submission that failed.

A browser never refills a file input, so a study file or form rejected for one typo would make
the experimenter choose every file again. Instead the files of a failed submission are kept on
the server under an unguessable token, in a folder of the experimenter's own
(``MEDIA_ROOT/staged/<user id>/<token>/<field>/<file name>``), and the page carries the token;
the next submission starts from the kept files, and a field given new files replaces its kept
ones. Whenever files are kept again, kept files older than :data:`KEEP_HOURS` are removed, and
so are all but the newest :data:`KEEP_ATTEMPTS` of the experimenter's attempts: what a session
of failed submissions can leave on the disk is bounded, and so is the sweep's own work.
"""

from __future__ import annotations

import re
import shutil
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from flask import current_app

from app.trials.fields import upload_name
from app.web.models import new_token

KEEP_HOURS = 24
#: Failed attempts kept per experimenter; an older one's token then finds nothing, and its
#: page asks for the files again.
KEEP_ATTEMPTS = 8
_TOKEN = re.compile(r"^[A-Za-z0-9_-]{20,64}$")


def safe_upload_name(filename: str) -> str:
    """The name an uploaded file is saved under: its last path part, or "" if unusable.

    Study files name their media by file name (``app.trials.fields.upload_name``), so the name
    is kept as it is, only the folder part is dropped; names that are no file name (".", "..",
    hidden files, control characters) are refused.

    >>> safe_upload_name("C:\\\\Users\\\\me\\\\speech.wav"), safe_upload_name("../.env")
    ('speech.wav', '')
    """

    name = upload_name(filename or "")
    if not name or name.startswith(".") or any(ord(c) < 32 or c == "\x7f" for c in name):
        return ""
    return name[:200]


def save_uploads(files: Iterable[Any], folder: Path) -> list[str]:
    """Save uploaded files (werkzeug ``FileStorage``) flat into ``folder``; their names.

    A field given files replaces what the folder held (the kept files of a failed attempt).
    """
    chosen = [f for f in files if f and safe_upload_name(getattr(f, "filename", "") or "")]
    if chosen:
        shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True, exist_ok=True)
    for upload in chosen:
        upload.save(folder / safe_upload_name(upload.filename))
    return sorted(p.name for p in folder.iterdir() if p.is_file())


def _root(user_id: int) -> Path:
    return Path(current_app.config["MEDIA_ROOT"]) / "staged" / str(int(user_id))


def keep(folder: Path, user_id: int) -> str:
    """Keep the files under ``folder`` for the experimenter's next attempt; the token."""
    root = _root(user_id)
    root.mkdir(parents=True, exist_ok=True)
    cutoff = time.time() - KEEP_HOURS * 3600
    # newest first: a token starts with the time it was made, in fixed-width hex
    for rank, old in enumerate(sorted(root.iterdir(), reverse=True)):
        if rank >= KEEP_ATTEMPTS - 1 or old.stat().st_mtime < cutoff:
            shutil.rmtree(old, ignore_errors=True)
    token = f"{time.time_ns():016x}{new_token(24)}"
    shutil.copytree(folder, root / token)
    return token


def restore(token: str | None, user_id: int, folder: Path) -> bool:
    """Copy the files kept under ``token`` into ``folder``; False if there are none.

    Only this experimenter's tokens are looked up, so a token copied from someone else's page
    finds nothing.
    """
    if not token or not _TOKEN.match(token):
        return False
    kept = _root(user_id) / token
    if not kept.is_dir():
        return False
    shutil.copytree(kept, folder, dirs_exist_ok=True)
    return True


def discard(token: str | None, user_id: int) -> None:
    """Remove the files kept under ``token`` (the study was created from them)."""
    if token and _TOKEN.match(token):
        shutil.rmtree(_root(user_id) / token, ignore_errors=True)


def kept_names(folder: Path) -> dict[str, list[str]]:
    """File names per form field in ``folder`` (what the page lists as kept)."""
    if not folder.is_dir():
        return {}
    return {
        field.name: sorted(p.name for p in field.iterdir() if p.is_file())
        for field in sorted(folder.iterdir())
        if field.is_dir()
    }
