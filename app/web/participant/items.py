"""The parallel design's versions: each served by its place on the trial's page only
(docs/reference/web.md, "Blinding"), so neither its URL nor its file name tells the hidden
reference."""

from __future__ import annotations

import sqlalchemy as sa
from flask import abort

from app.web.extensions import db
from app.web.models import Stimulus, Trial
from app.web.participant import bp
from app.web.participant.views import _participant, _send_video
from app.web.study.ratings import shown_items


@bp.get("/p/<token>/video/<int:trial_id>/item/<int:item>")
def item_video(token: str, trial_id: int, item: int):  # type: ignore[no-untyped-def]
    """Item ``item`` (0, 1, ... in the order shown) of a ``parallel`` trial: named by its place
    only, so neither the URL nor the file name tells the hidden reference."""
    participant = _participant(token)
    trial = db.session.get(Trial, trial_id)
    if (
        trial is None
        or trial.participant_id != participant.id
        or participant.study.design != "parallel"
    ):
        abort(404)
    items = shown_items(participant, trial)
    if item >= len(items):
        abort(404)
    stimulus = db.session.scalar(
        sa.select(Stimulus).where(
            Stimulus.clip_id == trial.stimulus.clip_id,
            Stimulus.left_id == items[item].id,
            Stimulus.right_id == items[item].id,
        )
    )
    if stimulus is None:
        abort(404)
    name = f"clip-{trial.position + 1:02d}-{item + 1}.mp4"
    return _send_video(participant.study, stimulus.video_path, name)
