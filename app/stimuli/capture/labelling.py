"""Marker labelling: the neutral first frame, spatial locality, and gap recovery.

Thesis sec. 3.1.3:

* the subject starts in the neutral pose (nose to the camera, head straight, face relaxed,
  lips together), so every marker has a known relative place. The frame's markers are the
  two uppermost and the two bottommost in the image; the face markers are then found by
  where they lie inside the frame (:data:`~app.stimuli.capture.markerset.NEUTRAL_LAYOUT`,
  mapped into the image through the four post markers, each spot matched to the nearest
  place by an optimal assignment, a spot farther than half the way to a neighbouring place
  matching nothing);
* later frames: a marker is found "in or near the same area" as in the frame before
  (spatial locality): each marker's predicted place (its last place plus its last step) is
  matched to the spots of the new frame by an optimal assignment, within a radius of 0.45
  times its distance to the nearest other marker in the neutral frame;
* a marker not found near its prediction is looked for where the least-squares affine motion
  of the markers found has taken it, frame after frame (a marker lost for a few frames while
  the head turns is found again);
* a marker not found is recovered by interpolating between the last place at which it was
  present and the first at which it is found again; a gap longer than ``max_gap_s`` (or a
  marker lost at the end for longer) is an error naming the marker and the frames.

Example
-------
>>> from app.stimuli.capture.markerset import MARKERS
>>> layout = {"lip_top": (0.5, 0.5)}
>>> spots = np.array([[10.0, 10], [90, 10], [50, 52], [10, 90], [90, 90]])
>>> tracker = MarkerTracker(spots, 0.0, names=("TL", "TR", "BL", "BR", "lip_top"),
...                         layout=layout)
>>> tracker.update(spots + 1.0, 1 / 30)
>>> tracker.finish().positions[1, 4].tolist()
[51.0, 53.0]
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from app.errors import InputError
from app.stimuli.capture.markerset import MARKERS, NEUTRAL_LAYOUT, POSTS
from app.stimuli.capture.timeline import MAX_GAP_S, _runs

#: Matching radius of a marker in later frames, as a share of its nearest neighbour's distance
#: in the neutral frame; and the same for the first frame's layout places.
TRACK_RADIUS, LAYOUT_RADIUS = 0.45, 0.5


@dataclass
class MarkerTracks:
    """Labelled marker positions over a clip.

    positions : (n_frames, n_markers, 2) pixels (x right, y down), gaps recovered.
    seen : (n_frames, n_markers) whether the marker was found in that frame.
    times : (n_frames,) seconds.
    names : marker names, the columns of ``positions``.
    report : ``lost`` (frames lost per marker) and ``gaps`` (marker, first and last frame).
    """

    positions: np.ndarray
    seen: np.ndarray
    times: np.ndarray
    names: tuple[str, ...] = MARKERS
    report: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.positions[:, self.names.index(name)]


def frame_label(k: int, t: float) -> str:
    return f"frame {k} ({t:.3f} s)"


def label_neutral(
    spots: np.ndarray,
    t: float = 0.0,
    *,
    names: tuple[str, ...] = MARKERS,
    layout: Mapping[str, tuple[float, float]] = NEUTRAL_LAYOUT,
    path: str | None = None,
) -> np.ndarray:
    """Positions of ``names`` (four posts first) in the neutral first frame, (n, 2).

    Raises an :class:`InputError` naming the first marker it cannot find.
    """
    spots = np.asarray(spots, dtype=np.float64).reshape(-1, 2)
    where = frame_label(0, t)
    if len(spots) < len(POSTS):
        raise InputError(
            f"{where}: {len(spots)} bright spots, fewer than the head frame's "
            "4 post markers (the first frame must show every marker in the "
            "neutral pose)",
            path=path,
        )
    by_height = np.argsort(spots[:, 1], kind="stable")
    top = spots[by_height[:2]][np.argsort(spots[by_height[:2], 0])]
    bottom = spots[by_height[-2:]][np.argsort(spots[by_height[-2:], 0])]
    posts = np.vstack([top, bottom])  # TL, TR, BL, BR
    rest = spots[by_height[2:-2]]
    face = [n for n in names if n not in POSTS]
    uv = np.array([layout[n] for n in face]).reshape(-1, 2)
    u, v = uv[:, :1], uv[:, 1:]
    places = (
        (1 - u) * (1 - v) * posts[0]
        + u * (1 - v) * posts[1]
        + (1 - u) * v * posts[2]
        + u * v * posts[3]
    )
    found = _match(places, rest, LAYOUT_RADIUS * _nearest(np.vstack([posts, places]))[4:])
    for k, name in enumerate(face):
        if found[k] < 0:
            x, y = places[k]
            raise InputError(
                f"{where}: marker {name} not found near ({x:.0f}, {y:.0f}) px "
                f"({len(spots)} bright spots; the first frame must show all "
                f"{len(names)} markers in the neutral pose)",
                path=path,
            )
    return np.vstack([posts, rest[found]])


def _nearest(points: np.ndarray) -> np.ndarray:
    """Each point's distance to the nearest other point."""
    d = np.linalg.norm(points[:, None] - points[None], axis=2)
    np.fill_diagonal(d, np.inf)
    return d.min(axis=1)


def _affine(before: np.ndarray, after: np.ndarray):
    """The least-squares affine map taking ``before`` (k >= 3, 2) to ``after``."""
    design = np.column_stack([before, np.ones(len(before))])
    coef = np.linalg.lstsq(design, after, rcond=None)[0]
    return lambda p: np.column_stack([p, np.ones(len(p))]) @ coef


def _match(predicted: np.ndarray, spots: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Index of the spot matched to each prediction (-1: none within its radius)."""
    out = np.full(len(predicted), -1)
    if len(spots) == 0 or len(predicted) == 0:
        return out
    d = np.linalg.norm(predicted[:, None] - spots[None], axis=2)
    far = d > radius[:, None]
    rows, cols = linear_sum_assignment(np.where(far, 1e9, d))
    keep = ~far[rows, cols]
    out[rows[keep]] = cols[keep]
    return out


class MarkerTracker:
    """Labels the spots of each frame of a clip, the first frame being the neutral pose."""

    def __init__(
        self,
        spots: np.ndarray,
        t: float,
        *,
        names: tuple[str, ...] = MARKERS,
        layout: Mapping[str, tuple[float, float]] = NEUTRAL_LAYOUT,
        max_gap_s: float = MAX_GAP_S,
        path: str | None = None,
    ) -> None:
        self.names, self.max_gap_s, self.path = names, max_gap_s, path
        first = label_neutral(spots, t, names=names, layout=layout, path=path)
        self.radius = TRACK_RADIUS * _nearest(first)
        self.positions = [first]
        self.seen = [np.ones(len(names), bool)]
        self.times = [float(t)]
        self.last = first.copy()
        self.step = np.zeros_like(first)

    def update(self, spots: np.ndarray, t: float) -> None:
        """Label the spots of the next frame (time ``t`` seconds)."""
        spots = np.asarray(spots, dtype=np.float64).reshape(-1, 2)
        found = _match(self.last + self.step, spots, self.radius)
        lost = np.flatnonzero(found < 0)
        moved = None
        if len(lost) and (found >= 0).sum() >= 3:
            # a lost marker is looked for where the motion of the others has taken it
            moved = _affine(self.last[found >= 0], spots[found[found >= 0]])
            free = np.setdiff1d(np.arange(len(spots)), found[found >= 0])
            again = _match(moved(self.last[lost]), spots[free], self.radius[lost])
            found[lost[again >= 0]] = free[again[again >= 0]]
        seen = found >= 0
        now = np.where(seen[:, None], spots[np.maximum(found, 0)], np.nan)
        was_seen = self.seen[-1]
        self.step = np.where((seen & was_seen)[:, None], now - self.last, 0.0)
        self.last = np.where(seen[:, None], now, self.last if moved is None else moved(self.last))
        self.positions.append(now)
        self.seen.append(seen)
        self.times.append(float(t))

    def finish(self) -> MarkerTracks:
        """Recover the gaps (linear in time between the last and first sighting)."""
        pos, seen = np.array(self.positions), np.array(self.seen)
        times = np.array(self.times)
        gaps: list[list[Any]] = []
        for k, name in enumerate(self.names):
            if seen[:, k].all():
                continue
            for a, b in _runs(~seen[:, k]):
                before = times[a - 1]
                after = times[b] if b < len(times) else times[b - 1]
                if after - before > self.max_gap_s + 1e-9:
                    end = (
                        "until the end" if b == len(times) else f"until {frame_label(b, times[b])}"
                    )
                    raise InputError(
                        f"marker {name} lost from {frame_label(a, times[a])} {end}, longer "
                        f"than the {self.max_gap_s:g} s recovered by interpolating between "
                        "its last and first sightings",
                        path=self.path,
                    )
                gaps.append([name, a, b - 1])
            ok = seen[:, k]
            for axis in (0, 1):
                pos[:, k, axis] = np.interp(times, times[ok], pos[ok, k, axis])
        lost = {
            n: int((~seen[:, k]).sum()) for k, n in enumerate(self.names) if not seen[:, k].all()
        }
        return MarkerTracks(pos, seen, times, self.names, {"lost": lost, "gaps": gaps})
