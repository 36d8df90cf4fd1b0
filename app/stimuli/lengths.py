"""Whether a captured or imported track is as long as the speech it goes with.

A ground truth (thesis sec. 4.3.2) or a researcher's own system's track is aligned to the
audio frame for frame (:func:`app.stimuli.track.align_to_features`): a shorter track is padded
by holding its last frame, a longer one is cut. A frame or so either way is the rounding of a
frame count or an audio encoder's priming; more than that usually means the wrong file, a take
cut at another point, or another frame rate than the file claims. A face that freezes for its
last seconds, or motion that belongs to words not heard, must not reach a study unnoticed, so:

- a difference of at most one frame passes silently;
- up to :data:`LENGTH_TOLERANCE_S` the track is padded or cut and one line says so;
- beyond it the track is refused in one line naming it, unless the study (``pad = true``) or
  the command (``--pad``) allows padding and cutting explicitly; the line is then a note.

Example
-------
>>> import numpy as np
>>> from app.stimuli.track import MotionTrack
>>> t = MotionTrack.zeros(30, 116, (48,))
>>> length_note(t, 120, 30.0, what="ground truth")
'ground truth: 3.87 s of motion for 4.00 s of speech: the last 0.13 s hold its last frame'
>>> length_note(MotionTrack.zeros(30, 90, (48,)), 120, 30.0, what="ground truth", path="gt.csv")
... # doctest: +ELLIPSIS
Traceback (most recent call last):
...
app.errors.InputError: gt.csv: ground truth: 3.00 s of motion for 4.00 s of speech: 1.00 s ...
>>> length_note(MotionTrack.zeros(30, 121, (48,)), 120, 30.0, what="x") is None
True
"""

from __future__ import annotations

from app.errors import InputError
from app.stimuli.track import MotionTrack

#: The largest difference (seconds) between a track and its speech that is padded or cut
#: without being asked: well above a frame count's rounding and an audio encoder's priming
#: (tens of milliseconds), below a word (about 0.25 s), so a misplaced take is never hidden.
LENGTH_TOLERANCE_S = 0.2


def length_note(
    track: MotionTrack,
    n_frames: int,
    fps: float,
    *,
    what: str,
    path: str | None = None,
    offset: float = 0.0,
    pad: bool = False,
    tolerance: float = LENGTH_TOLERANCE_S,
) -> str | None:
    """The line owed for aligning ``track`` (started ``offset`` s after the audio) to speech of
    ``n_frames`` frames at ``fps``; ``None`` when it differs by at most one frame.

    Raises an :class:`InputError` naming ``what`` (and the file, ``path``) when the difference
    is beyond ``tolerance`` seconds and ``pad`` is false.
    """
    speech = n_frames / fps
    end = offset + track.duration
    gap = speech - end
    if abs(gap) <= 1.0 / fps + 1e-9:
        return None
    head = f"{what}: {track.duration:.2f} s of motion for {speech:.2f} s of speech"
    if offset:
        head += f" (starting {offset:+.2f} s)"
    if gap > 0:
        done = f"the last {gap:.2f} s hold its last frame"
    else:
        done = f"its last {-gap:.2f} s are cut"
    if abs(gap) > tolerance and not pad:
        raise InputError(
            f"{head}: {abs(gap):.2f} s {'short' if gap > 0 else 'too long'}, beyond the "
            f"{tolerance:g} s tolerance; check the file, or allow padding and cutting "
            "(--pad, or pad = true in the study file)",
            path=path,
        )
    return f"{head}: {done}"
