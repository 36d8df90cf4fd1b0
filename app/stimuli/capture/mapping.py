"""One tracker-to-FAP mapping table: angles, weighted sums, eyelid closure and jaw opening.

Each importer states its table as a :class:`FapMapping` (see ``openface.py`` and ``arkit.py``
for the tables and their sources, and docs/capture.md); :meth:`FapMapping.apply` turns the
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

import numpy as np

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

    def apply(
        self, column: Callable[[str], np.ndarray], available: set[str]
    ) -> dict[int, np.ndarray]:
        """FAP -> values for every FAP whose columns are all ``available``."""
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
