"""The speaker's F0 range: the pitch floor and ceiling Praat's analysis of a recording needs.

A pitch tracker searches between a floor and a ceiling; too wide a range lets it read a
multiple or a fraction of the voice's F0, too narrow a one cuts the voice off. The range is
estimated from the recording in two passes (De Looze & Hirst 2008, widely used with Praat):
a first pass over :data:`FIRST_PASS_RANGE`, its octave errors removed
(:func:`remove_octave_jumps`), then a floor and a ceiling from the quartiles of its voiced F0
(:func:`speaker_pitch_range`). :mod:`app.stimuli.speech` runs both passes and removes the
second pass's octave errors before the F0 is conditioned (thesis sec. 4.3.4.1, eq. 35).
"""

from __future__ import annotations

import numpy as np

#: First-pass F0 range of the two-pass estimate (De Looze & Hirst 2008), Hz.
FIRST_PASS_RANGE = (60.0, 750.0)
#: Second-pass range from the first pass's quartiles: floor = 0.75 x q25, ceiling = 1.5 x q75.
FLOOR_FACTOR, CEILING_FACTOR = 0.75, 1.5
#: The range is widened towards the first pass's extremes at most this factor beyond the
#: quartiles (De Looze & Hirst's ceiling for expressive speech).
WIDEST = 2.5
#: Fewest voiced first-pass frames to trust the quartiles; fewer keeps the first-pass range.
MIN_VOICED_FOR_RANGE = 10
#: A voiced frame further than this (octaves) from the median of its neighbourhood is an error.
OCTAVE_JUMP = 0.6
#: Neighbourhood of that median, seconds (centred; voiced frames only).
OCTAVE_WINDOW_S = 0.3


def speaker_pitch_range(
    first_pass_f0: np.ndarray,
    floor: float | None = None,
    ceiling: float | None = None,
    fps: float = 30.0,
) -> tuple[float, float, str]:
    """The speaker's F0 floor and ceiling: given values kept where they hold the speaker,
    the rest from the first pass's distribution.

    Two-pass rule of De Looze & Hirst (2008), widely used with Praat: a first pass over
    :data:`FIRST_PASS_RANGE`, its octave jumps removed (:func:`remove_octave_jumps`), then
    ``floor = 0.75 * q25`` and ``ceiling = 1.5 * q75`` of its voiced F0, widened to 0.9 x its
    2nd and 1.1 x its 98th percentile where the speaker reaches further (a glide, wide
    intonation), but never past ``q25 / 2.5`` and ``2.5 * q75`` (:data:`WIDEST`: the first
    pass of a voice at its floor holds a few octave errors its jump removal misses). With
    fewer than :data:`MIN_VOICED_FOR_RANGE` voiced frames the first-pass range stands. A
    given floor above the speaker's first quartile, or a given ceiling below
    the third, does not hold the speaker: a 67 Hz bass analysed over 75-600 Hz read as 500 Hz
    in places, and the estimate replaces it, said in ``how``. Returns ``(floor, ceiling, how)``.

    >>> speaker_pitch_range(np.r_[np.zeros(5), np.linspace(100, 140, 41)])
    (82.5, 195.0, 'two-pass estimate (De Looze & Hirst 2008)')
    >>> speaker_pitch_range(np.full(40, 62.0), 75.0, 600.0)[2]
    'two-pass estimate: the given 75-600 Hz does not hold this speaker (median 62 Hz)'
    """
    voiced = np.asarray(first_pass_f0, dtype=np.float64)
    voiced, _ = remove_octave_jumps(voiced, fps)
    voiced = voiced[voiced > 0]
    estimate = None
    if len(voiced) >= MIN_VOICED_FOR_RANGE:
        q02, q25, q75, q98 = np.percentile(voiced, [2, 25, 75, 98])
        estimate = (  # widened by the extremes, never past 2.5 times the quartiles
            min(FLOOR_FACTOR * q25, max(0.9 * q02, q25 / WIDEST)),
            max(CEILING_FACTOR * q75, min(1.1 * q98, WIDEST * q75)),
        )
    if floor is not None and ceiling is not None:
        holds = estimate is None or (
            floor <= np.percentile(voiced, 25) and ceiling >= np.percentile(voiced, 75)
        )
        if holds:
            return float(floor), float(ceiling), "given"
        assert estimate is not None
        how = (
            f"two-pass estimate: the given {floor:g}-{ceiling:g} Hz does not hold this "
            f"speaker (median {np.median(voiced):.0f} Hz)"
        )
        return round(float(estimate[0]), 3), round(float(estimate[1]), 3), how
    if estimate is None:
        lo, hi = FIRST_PASS_RANGE
        how = "first-pass range (too little voicing to estimate the speaker's)"
    else:
        lo, hi = estimate
        how = "two-pass estimate (De Looze & Hirst 2008)"
    lo = float(floor) if floor is not None else float(lo)
    hi = float(ceiling) if ceiling is not None else float(hi)
    if hi <= lo:  # a given bound beyond the estimate of the other: keep an octave between them
        hi, lo = (2 * lo, lo) if floor is not None else (hi, hi / 2)
    return round(lo, 3), round(hi, 3), how


def remove_octave_jumps(
    f0: np.ndarray, fps: float, max_octaves: float = OCTAVE_JUMP, window_s: float = OCTAVE_WINDOW_S
) -> tuple[np.ndarray, int]:
    """Unvoice frames whose F0 jumps by about an octave from their neighbourhood.

    Autocorrelation pitch trackers halve or double F0 on a few frames (e.g. a 371 Hz frame in
    a 126 Hz male voice), and with a wide pitch range (a fixed 75-600 Hz for a 75 Hz voice) a
    short voiced stretch between pauses can read as a multiple of the voice's F0. A voiced
    frame whose F0 is more than ``max_octaves`` octaves from the median of its neighbourhood is
    set to 0 (unvoiced), so eq. 35's spline bridges it. The neighbourhood is the
    ``2 * round(window_s * fps / 2) + 1`` voiced frames nearest to it in order (shifted
    inwards at the ends of the recording): within ``window_s`` in fluent speech, and reaching
    across the pauses around an isolated stretch, whose own frames would otherwise be their
    only neighbours. A genuine pitch accent rises over 100-200 ms and stays within about half
    an octave of that median. Returns the cleaned F0 and the frames removed.

    >>> remove_octave_jumps(np.array([120, 122, 250, 121, 119, 0, 118.0]), 30.0)[0].tolist()
    [120.0, 122.0, 0.0, 121.0, 119.0, 0.0, 118.0]
    >>> isolated = np.r_[np.full(6, 80.0), np.zeros(6), np.full(3, 360.0), np.zeros(6), 80, 81]
    >>> remove_octave_jumps(isolated, 30.0)[1]
    3
    """
    f0 = np.asarray(f0, dtype=np.float64).copy()
    idx = np.flatnonzero(f0 > 0)
    if len(idx) < 3:
        return f0, 0
    half = max(int(round(window_s * fps / 2)), 1)
    width = min(2 * half + 1, len(idx))
    log_f0 = np.log2(f0[idx])
    starts = np.clip(np.arange(len(idx)) - half, 0, len(idx) - width)
    medians = np.median(log_f0[starts[:, None] + np.arange(width)], axis=1)
    bad = idx[np.abs(log_f0 - medians) > max_octaves]
    f0[bad] = 0.0
    return f0, int(len(bad))
