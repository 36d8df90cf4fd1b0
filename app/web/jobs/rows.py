"""A job's row as every runner writes it: how often a live job signs of life
(:func:`beat_interval`), and its failure (:func:`mark_failed`) with the message the
experimenter reads (:func:`failure_message`).
"""

from __future__ import annotations

import re
from pathlib import Path

import sqlalchemy as sa

from app.errors import InputError
from app.web.extensions import transaction
from app.web.infra.storage import disk_full, disk_full_message
from app.web.models import Job, utcnow


def beat_interval(stale_after: float) -> float:
    """How often a live job (or a queued one's holder) signs of life: well inside the time
    after which the sweeper gives it up (a fifth of it, at most 30 s)."""
    return max(0.05, min(30.0, stale_after / 5))


def mark_failed(job_id: int, reason: str) -> bool:
    """Mark an unfinished job failed with ``reason``; False if it had already finished."""
    with transaction() as session:
        result = session.execute(
            sa.update(Job)
            .where(Job.id == job_id, Job.status.in_(("queued", "running")))
            .values(status="failed", message=reason, finished_at=utcnow())
        )
    return result.rowcount == 1


def failure_message(exc: BaseException) -> str:
    """What the experimenter reads on a failed job's row."""
    if disk_full(exc):
        return disk_full_message(exc)  # type: ignore[arg-type]
    if isinstance(exc, InputError):
        # The file's name only: the experimenter uploaded it; its folder on the server is ours.
        where = Path(exc.path).name if exc.path else ""
        text = str(InputError(exc.message, path=where or None, line=exc.line, field=exc.field))
    else:
        text = str(exc)
    # No server path or internal exception name on the page; the log keeps both.
    text = _ABSOLUTE_PATH.sub(lambda match: Path(match.group(0)).name, text)
    name = type(exc).__name__
    if text.startswith(f"{name}: "):
        text = text[len(name) + 2 :]
    return text or "the job stopped with an internal error; the server log has the details"


#: An absolute POSIX path in an error message (the file name is kept).
_ABSOLUTE_PATH = re.compile(r"(?<![\w.:/])/(?:[^\s/:'\"]+/)+[^\s/:'\",;)]*")
