"""Which renditions of a participant's clips exist: the MP4 always, the WebM (VP9 + Opus, for
browsers without H.264) where the render made one (``Stimulus.webm_path``,
:mod:`app.web.jobs.renditions`). The pages and the answers offer only what exists, so a study
rendered before renditions plays from its MP4s alone."""

from __future__ import annotations

import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Stimulus, Trial


def versions_have_webm(clip_id: int) -> bool:
    """Whether every single-face version of clip ``clip_id`` (the ``parallel`` design's
    versions and its reference) has its WebM."""
    missing = db.session.scalar(
        sa.select(Stimulus.id)
        .where(
            Stimulus.clip_id == clip_id,
            Stimulus.left_id == Stimulus.right_id,
            Stimulus.webm_path.is_(None),
        )
        .limit(1)
    )
    return missing is None


def webm_offered(participant: Participant) -> bool:
    """Whether any clip of the participant's schedule came with a WebM to play."""
    found = db.session.scalar(
        sa.select(Trial.id)
        .join(Stimulus, Trial.stimulus_id == Stimulus.id)
        .where(Trial.participant_id == participant.id, Stimulus.webm_path.is_not(None))
        .limit(1)
    )
    return found is not None
