"""The parallel design's versions: each served by its place on the trial's page only
(docs/reference/web.md, "Blinding"), so neither its URL nor its file name tells the hidden
reference."""

from __future__ import annotations

from typing import NamedTuple

import sqlalchemy as sa
from flask import abort

from app.web.extensions import db
from app.web.models import Stimulus, Study, Trial
from app.web.participant.blueprint import bp
from app.web.participant.views import _participant, _send_video
from app.web.study.ratings import shown_items


@bp.get("/p/<token>/video/<int:trial_id>/item/<int:item>")
def item_video(token: str, trial_id: int, item: int):  # type: ignore[no-untyped-def]
    """Item ``item`` (0, 1, ... in the order shown) of a ``parallel`` trial: named by its place
    only, so neither the URL nor the file name tells the hidden reference."""
    stimulus = _item(token, trial_id, item)
    name = f"clip-{stimulus.trial.position + 1:02d}-{item + 1}.mp4"
    return _send_video(stimulus.study, stimulus.video_path, name)


@bp.get("/p/<token>/webm/<int:trial_id>/item/<int:item>")
def item_webm(token: str, trial_id: int, item: int):  # type: ignore[no-untyped-def]
    """The WebM rendition of :func:`item_video`, named as it is."""
    stimulus = _item(token, trial_id, item)
    name = f"clip-{stimulus.trial.position + 1:02d}-{item + 1}.webm"
    return _send_video(stimulus.study, stimulus.webm_path, name, "video/webm")


class _Item(NamedTuple):
    study: Study
    trial: Trial
    video_path: str | None
    webm_path: str | None


def _item(token: str, trial_id: int, item: int) -> _Item:
    """The stored clip of item ``item`` of the participant's ``parallel`` trial; 404 when
    there is none."""
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
    return _Item(participant.study, trial, stimulus.video_path, stimulus.webm_path)
