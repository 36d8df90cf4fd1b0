"""One tracker-to-FAP mapping table: angles, weighted sums, eyelid closure and jaw opening.

Each importer states its table as a :class:`FapMapping` (see ``openface.py`` and ``arkit.py``
for the tables and their sources, and docs/reference/capture.md); :meth:`FapMapping.apply` turns the
tracker's columns into FAP columns, and :meth:`FapMapping.needs` says which FAPs a file cannot
give for want of which column.

Example
-------
>>> m = FapMapping(angles={48: ("pitch", 1.0)}, sums={31: {"up": 10.0, "down": -10.0}})
>>> cols = {"pitch": np.array([0.01]), "up": np.array([2.0]), "down": np.array([0.5])}
>>> {k: v.round(3).tolist() for k, v in m.apply(cols.__getitem__, set(cols)).items()}
{48: [1000.0], 31: [15.0]}
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.capture.timeline import MAX_GAP_S, to_track
from app.stimuli.fap import AU_RADIANS
from app.stimuli.track import MotionTrack

#: Lid closure at a closed eye (IRISD units) and its share on the upper (19, 20) and lower
#: (21, 22) lids, as the renderer and the live eyelid model use them.
IRISD_CLOSED = 1024.0
LID_SHARE = {19: 0.8, 20: 0.8, 21: 0.2, 22: 0.2}


@dataclass(frozen=True)
class FapMapping:
    """FAP columns from tracker columns.

    angles : FAP -> (column in radians, sign); the FAP is ``sign * column / 1e-5`` (AU).
    sums : FAP -> {column: weight}; the FAP is the weighted sum (FAPU).
    lids : FAP -> (column, value of a closed lid); closure fraction ``clip(x / closed, 0, 1)``
        times ``LID_SHARE[fap] * 1024`` IRISD.
    """

    angles: Mapping[int, tuple[str, float]] = field(default_factory=dict)
    sums: Mapping[int, Mapping[str, float]] = field(default_factory=dict)
    lids: Mapping[int, tuple[str, float]] = field(default_factory=dict)

    def limit(self, track: MotionTrack) -> MotionTrack:
        """Eyelid closures back into 0..closed after resampling (a low-pass rings at blinks)."""
        lids = {
            c: np.clip(track[c], 0.0, LID_SHARE[c] * IRISD_CLOSED)
            for c in self.lids
            if c in track.channels
        }
        return track.with_channels(lids) if lids else track

    def columns_of(self, fap: int) -> tuple[str, ...]:
        if fap in self.angles:
            return (self.angles[fap][0],)
        if fap in self.lids:
            return (self.lids[fap][0],)
        return tuple(self.sums[fap])

    @property
    def faps(self) -> tuple[int, ...]:
        return tuple(dict.fromkeys([*self.angles, *self.sums, *self.lids]))

    def needs(self, available: set[str]) -> dict[str, list[int]]:
        """Missing column -> the FAPs it would have given."""
        out: dict[str, list[int]] = {}
        for fap in self.faps:
            for name in self.columns_of(fap):
                if name not in available:
                    out.setdefault(name, []).append(fap)
        return out

    def constant(
        self, column: Callable[[str], np.ndarray], available: set[str]
    ) -> tuple[dict[str, float], list[int], list[str]]:
        """The columns the table reads that hold one value in every frame, the FAPs whose
        columns are all 0 in every frame (a take recorded without them: head rotation off,
        a tool that writes no eyes), and the one-line warnings that say so.

        >>> m = FapMapping(angles={48: ("pitch", 1.0)}, sums={3: {"jaw": 800.0}})
        >>> cols = {"pitch": np.zeros(3), "jaw": np.array([0.1, 0.2, 0.1])}
        >>> m.constant(cols.__getitem__, set(cols))[:2]
        ({'pitch': 0.0}, [48])
        """
        used = [n for n in dict.fromkeys(n for f in self.faps for n in self.columns_of(f))]
        held: dict[str, float] = {}
        for name in used:
            if name in available:
                values = column(name)
                finite = values[np.isfinite(values)]
                if finite.size and np.all(finite == finite[0]):
                    held[name] = float(finite[0])
        zero = {n for n, v in held.items() if v == 0.0}
        left_out = [
            f
            for f in self.faps
            if all(n in available for n in self.columns_of(f))
            and all(n in zero for n in self.columns_of(f))
        ]
        lines = []
        if held:
            lines.append(
                "constant in every frame: " + ", ".join(f"{n} = {v:.6g}" for n, v in held.items())
            )
        if left_out:
            lines.append(
                f"FAP {', '.join(map(str, left_out))} left out: their columns are 0 in every "
                "frame (recorded without them), not a still face"
            )
        return held, left_out, lines

    def apply(
        self, column: Callable[[str], np.ndarray], available: set[str]
    ) -> dict[int, np.ndarray]:
        """FAP -> values for every FAP whose columns are all ``available`` (a value that
        overflows is infinite, a lost sample for :func:`to_track`)."""
        with np.errstate(over="ignore", invalid="ignore"):
            return self._apply(column, available)

    def _apply(
        self, column: Callable[[str], np.ndarray], available: set[str]
    ) -> dict[int, np.ndarray]:
        out: dict[int, np.ndarray] = {}
        for fap in self.faps:
            if not all(name in available for name in self.columns_of(fap)):
                continue
            if fap in self.angles:
                name, sign = self.angles[fap]
                out[fap] = sign * column(name) / AU_RADIANS
            elif fap in self.lids:
                name, closed = self.lids[fap]
                closure = np.clip(column(name) / closed, 0.0, 1.0)
                out[fap] = LID_SHARE[fap] * IRISD_CLOSED * closure
            else:
                terms = [w * column(name) for name, w in self.sums[fap].items()]
                out[fap] = np.sum(terms, axis=0)
        return out


def columns_to_track(
    mapping: FapMapping,
    times: np.ndarray,
    column: Callable[[str], np.ndarray],
    available: set[str],
    *,
    fps: float,
    source: str,
    path: str,
    name: str = "",
    rows: np.ndarray | None = None,
    max_gap_s: float = MAX_GAP_S,
    recorded: Callable[[str], np.ndarray] | None = None,
) -> MotionTrack:
    """A track from the columns of a weight file (ARKit blendshapes and rotations) at their
    ``times`` (seconds, one sample per row): :meth:`FapMapping.apply`, the FAPs of all-zero
    columns left out (:meth:`FapMapping.constant`, judged on the ``recorded`` columns when
    ``column`` gives them relative to a rest), then
    :func:`~app.stimuli.capture.timeline.to_track`. ``metadata["capture"]`` adds
    ``missing``, ``constant``, ``left_out`` and ``warnings`` (one line each) to the time
    report."""
    faps = mapping.apply(column, available)
    held, left_out, warnings = mapping.constant(recorded or column, available)
    for fap in left_out:
        faps.pop(fap, None)
    if not faps:
        raise InputError(
            "no blendshape or rotation column to import"
            + (" (every mapped column is 0 in every frame)" if left_out else ""),
            path=path,
            line=1,
        )
    t = np.asarray(times, dtype=np.float64)
    track, report = to_track(
        t - (t[0] if len(t) and np.isfinite(t[0]) else 0.0),
        faps,
        np.ones(len(t), bool),
        fps=fps,
        path=path,
        max_gap_s=max_gap_s,
        rows=rows,
        name=name,
        source=source,
    )
    extra: dict[str, Any] = dict(
        missing=mapping.needs(available), constant=held, left_out=left_out, warnings=warnings
    )
    report.update(extra)
    return mapping.limit(track).replace(metadata={**track.metadata, "capture": report})
