"""The WebM rendition of a study's clips, beside each MP4: VP9 + Opus for browsers that cannot
play H.264 (WebKitGTK without its codec plugins, Linux builds of Firefox without the system's
codecs). The participant's page offers the MP4, then the WebM, and the browser plays the
first it can (``static/participant.js``).

A clip rendered now gets its WebM from the same frames in the same pass
(:func:`app.web.jobs.rendering.render_stimulus`); one rendered before renditions existed, or whose
WebM went missing, gets it here from its stored MP4 (:func:`add_webm`): the render job does so
for every clip it finds without one, and ``facepair study renditions`` does it for a study in
any state, since the WebM shows what the MP4 shows (docs/reference/web.md, "Renditions").
The WebM is named as its MP4 is, ``videos/<20 hex digits>.webm``, and blinded as it is.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import PurePosixPath

import sqlalchemy as sa

from app.web.extensions import db
from app.web.infra import media
from app.web.infra.storage import media_file
from app.web.models import Stimulus, Study


def webm_file(video_path: str) -> str:
    """The stored name of the WebM rendition of the clip stored as ``video_path``: the same
    name (an HMAC that names nothing, :func:`app.web.jobs.rendering.clip_file`), ending ``.webm``.

    >>> webm_file("videos/0f3a9c2b7d41e5a86b0c.mp4")
    'videos/0f3a9c2b7d41e5a86b0c.webm'
    """
    return str(PurePosixPath(video_path).with_suffix(".webm"))


def has_webm(study: Study, stim: Stimulus) -> bool:
    """Whether the stimulus's WebM rendition is recorded and in place."""
    return bool(stim.webm_path) and media.stored(study, stim.webm_path)  # type: ignore[arg-type]


def add_webm(study: Study, stim: Stimulus) -> str:
    """Make the WebM rendition of the stimulus's rendered MP4 (``renderer.encode.write_webm``),
    publish and record it; returns its path in the study's folder. Not committed."""
    from renderer.encode import write_webm

    if not stim.video_path:
        raise ValueError(f"stimulus {stim.id} has no rendered clip to make a WebM of")
    rel = webm_file(stim.video_path)
    write_webm(media.fetch(study, stim.video_path), media_file(study, rel))
    media.publish(study, rel)
    stim.webm_path = rel
    return rel


def without_webm(study: Study) -> list[Stimulus]:
    """The study's rendered stimuli that have no WebM rendition in place, in order."""
    rendered = db.session.scalars(
        sa.select(Stimulus)
        .where(Stimulus.study_id == study.id, Stimulus.video_path.is_not(None))
        .order_by(Stimulus.id)
    )
    return [s for s in rendered if not has_webm(study, s)]


def add_missing_webm(study: Study, progress: Callable[[int, int], None]) -> int:
    """:func:`add_webm` for every rendered stimulus of ``study`` without one, committed one
    by one (a stopped run keeps what it made); returns how many were made."""
    todo = without_webm(study)
    progress(0, len(todo))
    for done, stim in enumerate(todo, start=1):
        add_webm(study, stim)
        db.session.commit()
        progress(done, len(todo))
    return len(todo)
