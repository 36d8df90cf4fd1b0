"""Normalisation of condition tracks to a reference condition (thesis sec. 5.3).

For the thesis' second experiment the head motion of RANDOM, SPEECH_DRIVEN and GROUND_TRUTH was
"scaled and offset so that the FAPs of the three conditions contained the same standard
deviation and mean": viewers then judge the timing and shape of the motion, not its size. Per
condition and channel,

    x' = scale * x + offset,  scale = sd_ref / sd_x,  offset = mean_ref - scale * mean_x,

so ``x'`` has the reference's mean and standard deviation (population sd, ddof = 0). A channel
that is constant in a condition (e.g. NO_PROSODY's zeros) cannot be scaled and is left as it
is, and so is a channel the reference lacks; both are reported. Eyebrow channels may take small
negative values after the offset; that is the price of matching the mean.

Example
-------
>>> import numpy as np
>>> from app.stimuli.track import MotionTrack
>>> ref = MotionTrack.from_channels(30, {48: np.array([0.0, 2.0, 4.0])})
>>> other = MotionTrack.from_channels(30, {48: np.array([10.0, 11.0, 12.0])})
>>> tracks, factors = normalize_tracks({"ground_truth": ref, "random": other})
>>> tracks["random"][48].tolist(), factors["random"]["48"]["scale"]
([0.0, 2.0, 4.0], 2.0)
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.fap import EYEBROWS, HEAD
from app.stimuli.track import MotionTrack

#: Channels normalised by default: the prosody channels under study (head and eyebrows).
DEFAULT_CHANNELS: tuple[int, ...] = HEAD + EYEBROWS


def normalize_tracks(tracks: Mapping[str, MotionTrack], reference: str | MotionTrack =
                     "ground_truth", *, channels: Iterable[int] = DEFAULT_CHANNELS
                     ) -> tuple[dict[str, MotionTrack], dict[str, dict[str, Any]]]:
    """Give every track the reference's per-channel mean and sd; returns tracks and factors.

    ``reference`` is a key of ``tracks`` (that track is returned unchanged) or a track of its
    own (e.g. ground truth that is not itself one of the conditions). ``factors[condition][fap]``
    holds ``scale``, ``offset``, the means and sds before and the targets, or ``skipped`` with
    the reason.
    """
    if isinstance(reference, str):
        if reference not in tracks:
            raise InputError(f"normalisation reference {reference!r} is not among the "
                             f"conditions ({', '.join(tracks) or 'none'})", field="normalize")
        ref_track, ref_name = tracks[reference], reference
    else:
        ref_track, ref_name = reference, ""
    wanted = [c for c in channels]
    out: dict[str, MotionTrack] = {}
    factors: dict[str, dict[str, Any]] = {}
    for name, track in tracks.items():
        if name == ref_name:
            out[name] = track
            continue
        if track.n_frames != ref_track.n_frames:
            raise InputError(f"{name}: {track.n_frames} frames, reference has "
                             f"{ref_track.n_frames}", field="normalize")
        columns: dict[int, np.ndarray] = {}
        report: dict[str, Any] = {}
        for c in wanted:
            if c not in track.channels:
                continue
            if c not in ref_track.channels:
                report[str(c)] = {"skipped": "reference lacks this channel"}
                continue
            x, r = track[c], ref_track[c]
            mx, sx, mr, sr = float(x.mean()), float(x.std()), float(r.mean()), float(r.std())
            if sx == 0:
                report[str(c)] = {"skipped": "constant in this condition", "mean": mx}
                continue
            scale = sr / sx
            offset = mr - scale * mx
            columns[c] = (x - mx) * scale + mr
            report[str(c)] = {"scale": scale, "offset": offset, "mean_before": mx,
                              "std_before": sx, "mean_target": mr, "std_target": sr}
        meta = dict(track.metadata, normalized_to=ref_name or ref_track.source or "reference")
        out[name] = track.with_channels(columns).replace(metadata=meta)
        factors[name] = report
    return out, factors
