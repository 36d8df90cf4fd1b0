"""What the faces of a clip share: every channel the study does not test.

The thesis compares conditions that differ in head and eyebrow motion alone (sec. 4.3: "only
head and eyebrow motion are under study", the lips carried from the ground truth); Le, Ma &
Deng (2012, sec. 8) compare head and eye motion with the mouth hidden. Whatever else differs
between the two faces of a pair is a confound participants can judge instead: a face that never
blinks beside one that does, a mouth that moves under the mosaic beside one that does not. That
holds for a condition a researcher brings as much as for a built-in one, so after every
condition is generated (or imported) each clip's channels fall in three groups:

- **tested** (:data:`TESTED`: head 48-50 and eyebrows 31-38): each condition's own; only the
  head's rest posture is shared (:mod:`app.stimuli.posture`); the study's ``brows``
  (:data:`BROW_MODES`) may share the eyebrows too, none or the thesis' rule in every
  condition, for a study of head and eyes alone;
- **eyes** (:data:`EYE_GROUP`: eyelids 19-22, gaze 23-26, eyeball thrust and pupils 27-30): one
  set for every condition, by the study's ``eyes`` (:mod:`app.stimuli.eyes`); ``eyes = "own"``
  keeps each condition's own instead, and then every condition must carry eye motion;
- **the rest of the face** (:data:`FACE_GROUP`: jaw, lips, cheeks, tongue, nose, ears and the
  high-level FAPs 1-2), by the study's ``lips``: ``shared`` (the default under the mouth
  mosaic) gives every condition the ground truth's, or, without one, the first condition's
  (in the study's order) that moves them; ``own`` (the default of a study without the mosaic,
  which can compare lip motion) keeps each condition's own, and the summary says so.

After sharing, the channels outside :data:`TESTED` are identical, value for value, in every
condition of a clip: a channel one track has and another lacks is written into both (a FAP
absent from a track is neutral, 0).

Example
-------
>>> import numpy as np
>>> from app.stimuli.track import MotionTrack
>>> a = MotionTrack.from_channels(30, {48: np.ones(3), 3: np.array([0.0, 200.0, 0.0])})
>>> b = MotionTrack.from_channels(30, {48: np.zeros(3), 41: np.ones(3)})
>>> cols, source = face_channels("shared", {"a": a, "b": b})
>>> source, sorted(cols)
('condition a', [3])
>>> out = share_channels({"a": a, "b": b}, cols)
>>> out["b"][3].tolist(), out["a"][41].tolist(), out["b"][48].tolist()
([0.0, 200.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from app.errors import InputError
from app.stimuli.fap import EYEBROWS, EYELIDS, GAZE, HEAD, N_FAPS
from app.stimuli.track import MotionTrack

#: The channels a study tests: each condition's own.
TESTED: tuple[int, ...] = tuple(sorted(HEAD + EYEBROWS))
#: The eyes' channels, set by the study's ``eyes``.
EYE_GROUP: tuple[int, ...] = EYELIDS + GAZE + (27, 28, 29, 30)
#: Every other channel: the lower face and the rest, set by the study's ``lips``.
FACE_GROUP: tuple[int, ...] = tuple(
    c for c in range(1, N_FAPS + 1) if c not in TESTED and c not in EYE_GROUP
)
LIP_MODES: tuple[str, ...] = ("shared", "own")
DEFAULT_LIPS = "shared"
#: The study's ``brows``: each condition's own (the thesis' conditions differ in brows as in
#: head), none in any condition, or the thesis' speech-driven rule in every condition (a
#: study of head and eyes alone: Le et al.'s live model has no brows).
BROW_MODES: tuple[str, ...] = ("own", "none", "rule")
DEFAULT_BROWS = "own"


def check_brows(mode: str) -> str:
    """``mode`` if it is one of :data:`BROW_MODES`, else an InputError naming the field."""
    if mode not in BROW_MODES:
        raise InputError(
            f"brows must be one of {', '.join(BROW_MODES)}, got {mode!r}", field="brows"
        )
    return mode


def check_lips(mode: str) -> str:
    """``mode`` if it is one of :data:`LIP_MODES`, else an InputError naming the field."""
    if mode not in LIP_MODES:
        raise InputError(f"lips must be one of {', '.join(LIP_MODES)}, got {mode!r}", field="lips")
    return mode


def lips_for(lips: str | None, mosaic_block: int | None) -> str:
    """The ``lips`` mode of a study: its own choice, else ``shared`` under the mouth mosaic
    and ``own`` without it (``mosaic_block`` 0; None is the renderer's default, a mosaic).

    >>> lips_for(None, None), lips_for(None, 0), lips_for("shared", 0)
    ('shared', 'own', 'shared')
    """
    if lips is not None:
        return check_lips(lips)
    return "own" if mosaic_block == 0 else "shared"


def moves(track: MotionTrack, channels: tuple[int, ...]) -> bool:
    """Whether ``track`` carries any motion in ``channels`` (a channel at 0 throughout is
    none: an importer's zero columns, a built-in condition's neutral lips)."""
    kept = [c for c in channels if c in track.channels]
    return bool(kept) and bool(np.any(track.select(kept).values != 0))


def face_channels(
    mode: str,
    tracks: Mapping[str, MotionTrack],
    ground_truth: MotionTrack | None = None,
) -> tuple[dict[int, np.ndarray] | None, str]:
    """The :data:`FACE_GROUP` columns every condition gets under ``lips = mode``, and where
    they come from; ``None`` for ``own`` (each keeps its own).

    ``ground_truth`` must be aligned to the tracks (the same frames). Without one the first
    track in ``tracks``' order that moves these channels lends them; with none, they are 0.
    """
    check_lips(mode)
    if mode == "own":
        return None, "each condition's own"
    if ground_truth is not None:
        source, origin = ground_truth, "the ground truth"
    else:
        lender = next((n for n, t in tracks.items() if moves(t, FACE_GROUP)), None)
        if lender is None:
            return {}, "none moves them (neutral)"
        source, origin = tracks[lender], f"condition {lender}"
    return {c: source[c].copy() for c in FACE_GROUP if c in source.channels}, origin


def share_channels(
    tracks: Mapping[str, MotionTrack],
    columns: Mapping[int, np.ndarray],
    group: tuple[int, ...] = FACE_GROUP,
) -> dict[str, MotionTrack]:
    """Every track with ``group`` set to ``columns``: a channel of ``group`` that any track has
    but ``columns`` lacks is written as 0 into all, so that the group is identical in each."""
    present = {c for t in tracks.values() for c in t.channels if c in group}
    out: dict[str, MotionTrack] = {}
    for name, track in tracks.items():
        zeros = np.zeros(track.n_frames)
        cols = {c: np.asarray(columns[c]) if c in columns else zeros for c in present}
        cols.update({c: np.asarray(v) for c, v in columns.items()})
        out[name] = track.with_channels(cols)
    return out


def differing_channels(
    tracks: Mapping[str, MotionTrack], tested: tuple[int, ...] = TESTED
) -> list[int]:
    """The channels outside ``tested`` whose values differ between ``tracks`` (of one clip,
    of one length): empty when the faces share everything the study does not test."""
    dense = [t.dense() for t in tracks.values()]
    if len(dense) < 2:
        return []
    first, rest = dense[0], dense[1:]
    return [
        c
        for c in range(1, N_FAPS + 1)
        if c not in tested and any(not np.array_equal(first[:, c - 1], d[:, c - 1]) for d in rest)
    ]
