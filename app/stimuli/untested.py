"""What a study does not test, made the same in every condition of a clip after generation.

The step of :func:`app.stimuli.generate.generate_conditions` between generating the conditions
and measuring them (:mod:`app.stimuli.shared` says why and which channels): the ground truth's
rest head pose for every condition (``posture``, :mod:`app.stimuli.posture`); one set of eyes
(``eyes``, :mod:`app.stimuli.eyes`), or each condition's own, checked; the eyes of imported
meshes matched (``mesh_eyes``, :mod:`app.stimuli.meshes.fairness`); one lower face (``lips``);
the eyebrows by the study's ``brows``, none or the thesis' speech-driven rule (sec. 4.3.4.1)
in every condition.

Example
-------
>>> import numpy as np
>>> from app.stimuli.speech import SpeechFeatures
>>> from app.stimuli.track import MotionTrack
>>> features = SpeechFeatures(30.0, np.full(3, 120.0), np.full(3, 60.0), np.full(3, 120.0), {})
>>> a = MotionTrack.from_channels(30, {48: np.ones(3), 31: np.ones(3)})
>>> b = MotionTrack.from_channels(30, {48: np.zeros(3)})
>>> tracks, shared = share_untested(
...     {"a": a, "b": b}, [], features, None,
...     eyes="still", posture="per_condition", lips="shared", brows="none", mesh_eyes="match",
...     seed=0, notes=[],
... )
>>> shared["eyes_from"], shared["brows"], tracks["a"][31].tolist()
('still', {'mode': 'none', 'from': 'none (no eyebrow motion)'}, [0.0, 0.0, 0.0])
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from app.errors import InputError
from app.stimuli.eyes import eye_channels
from app.stimuli.fap import EYEBROWS
from app.stimuli.meshes.fairness import match_mesh_eyes
from app.stimuli.posture import rest_posture, share_posture
from app.stimuli.shared import EYE_GROUP, face_channels, moves, share_channels
from app.stimuli.speech import SpeechFeatures
from app.stimuli.track import MotionTrack


def share_untested(
    tracks: dict[str, MotionTrack],
    live: Sequence[str],
    features: SpeechFeatures,
    gt_aligned: MotionTrack | None,
    *,
    eyes: str,
    posture: str,
    lips: str,
    brows: str,
    mesh_eyes: str,
    seed: int,
    notes: list[str],
) -> tuple[dict[str, MotionTrack], dict[str, Any]]:
    """Every condition's track with the study's posture, eyes, mesh eyes, lips and brows,
    and the summary's record of where each came from (``eyes_from``, ``lips``, ``brows``,
    ``mesh_eyes`` when matched, ``posture``); what a user should know is added to ``notes``.

    ``live`` names the conditions of the live model (``live_gmm``), whose eyes ``eyes =
    "generated"`` shares and which move no eyebrow; ``gt_aligned`` is the ground truth on the
    speech's frames, if any.
    """
    rest = rest_posture(gt_aligned) if posture == "shared" else None
    if rest is not None:
        tracks = share_posture(tracks, rest)

    tracks, eyes_from = _share_eyes(tracks, live, eyes, features, gt_aligned, seed)
    tracks, mesh_eyes_note = match_mesh_eyes(tracks, mesh_eyes)
    notes += [mesh_eyes_note] if mesh_eyes_note else []
    face_cols, lips_from = face_channels(lips, tracks, gt_aligned)
    if face_cols is not None:
        tracks = share_channels(tracks, face_cols)
    elif len(tracks) > 1:
        notes.append(
            "lips = 'own': each condition keeps its own jaw and lip motion (for a study "
            "without the mouth mosaic that compares it)"
        )
    tracks, brows_from = _share_brows(tracks, live, brows, features, notes)

    shared: dict[str, Any] = {
        "eyes_from": eyes_from,
        "lips": {"mode": lips, "from": lips_from},
        "brows": {"mode": brows, "from": brows_from},
    }
    if mesh_eyes_note:
        shared["mesh_eyes"] = {"mode": mesh_eyes, "note": mesh_eyes_note}
    shared["posture"] = {
        "mode": posture,
        "rest_head_au": rest,
        "rest_from": None
        if rest is None
        else ("median of the ground truth" if gt_aligned is not None else "neutral"),
    }
    return tracks, shared


def _share_brows(
    tracks: dict[str, MotionTrack],
    live: Sequence[str],
    brows: str,
    features: SpeechFeatures,
    notes: list[str],
) -> tuple[dict[str, MotionTrack], str]:
    """Every track with the study's eyebrows (``brows``), and where they come from."""
    if brows == "own":
        moving = [n for n, t in tracks.items() if moves(t, EYEBROWS)]
        if live and moving:
            notes.append(
                f"{', '.join(live)} (live_gmm) moves no eyebrow, as Le et al.'s model has "
                f"none, while {', '.join(moving)} do: their pairs differ in the brows too; "
                "brows = 'none' or 'rule' gives every condition the same"
            )
        return tracks, "each condition's own"
    if brows == "none":
        return share_channels(tracks, {}, EYEBROWS), "none (no eyebrow motion)"
    from app.stimuli.conditions.speech_driven import SpeechDrivenCondition

    cols, _ = SpeechDrivenCondition().eyebrows(features)
    return share_channels(tracks, cols, EYEBROWS), "the thesis' speech-driven rule"


def _share_eyes(
    tracks: dict[str, MotionTrack],
    live: Sequence[str],
    eyes: str,
    features: SpeechFeatures,
    gt_aligned: MotionTrack | None,
    seed: int,
) -> tuple[dict[str, MotionTrack], str]:
    """Every track with the clip's eyes under ``eyes`` (:mod:`app.stimuli.eyes`), and where
    they come from; ``own`` checks that each condition has eyes of its own."""
    if eyes == "own":
        lacking = [n for n, t in tracks.items() if not moves(t, EYE_GROUP)]
        if lacking:
            named = ", ".join(
                f"{n} ({tracks[n].metadata['file']})" if "file" in tracks[n].metadata else n
                for n in lacking
            )
            raise InputError(
                f"eyes = 'own' keeps each condition's own eyes, but condition {named} "
                "carries no eye motion (FAPs 19-26 absent or 0): give it eye motion, or "
                "share generated eyes (eyes = 'generated')",
                field="eyes",
            )
        return tracks, "each condition's own"
    if eyes == "generated" and live:  # the live model's own eyes, for every face alike
        cols = {c: tracks[live[0]].get(c) for c in EYE_GROUP if c in tracks[live[0]].channels}
        eyes_from = f"condition {live[0]} (live_gmm)"
    else:
        cols = eye_channels(eyes, features, gt_aligned, seed=seed)
        eyes_from = {"generated": "the shipped live model"}.get(eyes, eyes)
    shared = share_channels(tracks, cols, EYE_GROUP)
    return {
        n: t.replace(metadata={**t.metadata, "eyes": eyes}) for n, t in shared.items()
    }, eyes_from
