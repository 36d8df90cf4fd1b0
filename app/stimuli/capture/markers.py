"""The thesis' marker capture: an IR video of retro-reflective markers -> a FAP track.

Thesis sec. 3.1.3-3.2.4, in order: segmentation of each frame (threshold, the 3x3 density
rule grown to the marker box, centres of gravity: :mod:`~app.stimuli.capture.blobs`);
labelling from the neutral first frame and spatial locality, with lost markers recovered
between their last and first sightings (:mod:`~app.stimuli.capture.labelling`); head pitch,
yaw and roll from the head frame, lip opening with its pitch correction, eyebrows with the
post-average correction, Gaussian squashing (:mod:`~app.stimuli.capture.marker_faps`); then
every sample placed at its time stamp and resampled to the study's rate
(:func:`~app.stimuli.capture.timeline.to_track`: dropped and duplicated frames at 29.97 fps),
and the 5-frame non-causal mean on the eyebrows. Docs: docs/reference/capture.md, "Marker capture".

Example
-------
>>> track = capture_markers("take.mp4", fps=30.0)            # doctest: +SKIP
>>> track.channels                                           # doctest: +SKIP
(4, 5, 6, 7, 12, 13, 31, 32, 33, 34, 48, 49, 50, 51, 52, 53, 54, 59, 60)
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from app.errors import InputError
from app.stimuli.capture.blobs import find_markers
from app.stimuli.capture.labelling import MarkerTracker, MarkerTracks
from app.stimuli.capture.marker_faps import (
    DEFAULT_CONSTANTS,
    MarkerConstants,
    marker_faps,
    mean_filter,
)
from app.stimuli.capture.timeline import MAX_GAP_S, to_track
from app.stimuli.fap import EYEBROWS
from app.stimuli.track import MotionTrack

#: Default segmentation threshold, grey levels of 0-255 (markers saturate, the face is dim).
THRESHOLD = 128.0


def label_frames(
    frames: Iterable[tuple[float, np.ndarray]],
    *,
    threshold: float = THRESHOLD,
    weights: str = "grey",
    max_gap_s: float = MAX_GAP_S,
    path: str | None = None,
    progress: Callable[[int], None] | None = None,
) -> MarkerTracks:
    """Segment and label ``(time, grey frame)`` pairs; the first is the neutral pose."""
    tracker: MarkerTracker | None = None
    for k, (t, grey) in enumerate(frames):
        spots = find_markers(grey, threshold, weights=weights)
        if tracker is None:
            tracker = MarkerTracker(spots, t, max_gap_s=max_gap_s, path=path)
        else:
            tracker.update(spots, t)
        if progress is not None:
            progress(k + 1)
    if tracker is None:
        raise InputError("no frames", path=path)
    return tracker.finish()


def tracks_to_faps(
    tracks: MarkerTracks,
    *,
    fps: float = 30.0,
    constants: MarkerConstants = DEFAULT_CONSTANTS,
    max_gap_s: float = MAX_GAP_S,
    path: str | None = None,
    name: str = "",
) -> MotionTrack:
    """The FAP track of labelled markers at ``fps``; its metadata holds the capture report."""
    columns = marker_faps(tracks, constants)
    track, report = to_track(
        tracks.times,
        columns,
        np.ones(len(tracks.times), bool),
        fps=fps,
        source="marker capture",
        path=path,
        max_gap_s=max_gap_s,
        rows=np.arange(len(tracks.times)),
        name=name,
    )
    brows = {
        f: mean_filter(track[f], constants.smooth_s, fps) for f in EYEBROWS if f in track.channels
    }
    report = {**report, "markers_lost": tracks.report["lost"], "marker_gaps": tracks.report["gaps"]}
    track = track.with_channels(brows)
    return track.replace(metadata={**track.metadata, "capture": report})


def capture_markers(
    path: str | Path,
    *,
    fps: float = 30.0,
    constants: MarkerConstants = DEFAULT_CONSTANTS,
    threshold: float = THRESHOLD,
    weights: str = "grey",
    max_gap_s: float = MAX_GAP_S,
    progress: Callable[[int, int], None] | None = None,
) -> MotionTrack:
    """Run the whole capture on a video file (any imageio-ffmpeg reads); see the module text.

    ``progress(done, total)`` is called after each frame (``total`` an estimate from the
    container, 0 if unknown).
    """
    from app.stimuli.capture.video import read_grey_frames, video_info

    info = video_info(path)
    report = None if progress is None else (lambda k: progress(k, info["n_frames"]))
    tracks = label_frames(
        read_grey_frames(path, info),
        threshold=threshold,
        weights=weights,
        max_gap_s=max_gap_s,
        path=str(path),
        progress=report,
    )
    return tracks_to_faps(
        tracks,
        fps=fps,
        constants=constants,
        max_gap_s=max_gap_s,
        path=str(path),
        name=Path(path).stem,
    )
