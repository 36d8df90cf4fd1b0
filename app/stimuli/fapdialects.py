"""The two dialects of MPEG-4 FAP stream files (.fap) that Xface and Greta play, and the
comment line that marks a file facepair wrote (:mod:`app.stimuli.fapfile` reads and writes them).

The mask's length says the dialect, and the dialect says how to count values:

========================  ================================  ====================================
mask position             Xface / MPEG-4, 68 values         Greta, 69 values
========================  ================================  ====================================
1                         FAP 1 viseme: 4 values            FAP 1 viseme: 1 value
2                         FAP 2 expression: 6 values        FAP 2 expression: 1 value
3 .. 68                   FAP 3 .. 68: 1 value each         FAP 3 .. 68: 1 value each
69                        (none)                            an extra entry, not a FAP: 1 value
========================  ================================  ====================================

Greta's FAP list has a null entry before FAP 1, which its writer skips, and one entry after
FAP 68, which it writes; so position i is FAP i in both dialects. The MPEG-4 widths of FAP 1
(select1, select2, blend, def) and FAP 2 (select1, intensity1, select2, intensity2, init_face,
def) hold in Xface's reader, while Greta writes one integer for every masked position.

A third layout is that of facepair's own early Greta-style files (first comment line exactly
:data:`WRITER_LINE`, 69-value masks): a null FAP 0 first and FAP i at position i + 1, with the
MPEG-4 widths (:data:`EARLY_FACEPAIR_GRETA`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from app.errors import InputError
from app.stimuli.fap import N_FAPS

#: Values a frame carries for the high-level FAPs in MPEG-4 and Xface (viseme: select1,
#: select2, blend, def; expression: select1, intensity1, select2, intensity2, init_face, def).
HIGH_LEVEL_WIDTH = {1: 4, 2: 6}
#: First line of every file facepair writes; alone, it also marks the early Greta-style files.
WRITER_LINE = "MPEG-4 FAP stream written by facepair"
GRETA_WRITER_LINE = WRITER_LINE + " in Greta's layout: FAP 1..68, then one extra entry"


@dataclass(frozen=True)
class Dialect:
    """How one dialect lays out a mask: the FAP at each position (0: none) and value widths."""

    name: str
    faps: tuple[int, ...]
    high_level_widths: bool  # True: MPEG-4's 4 and 6 values for FAP 1 and 2

    def width(self, fap: int) -> int:
        """How many values a masked ``fap`` carries on a value line."""
        return HIGH_LEVEL_WIDTH.get(fap, 1) if self.high_level_widths else 1


XFACE = Dialect(
    "68-value mask: Xface/MPEG-4, 4 values for FAP 1, 6 for FAP 2",
    tuple(range(1, N_FAPS + 1)),
    True,
)
GRETA = Dialect(
    "69-value mask: Greta, one value per masked position", (*range(1, N_FAPS + 1), 0), False
)
EARLY_FACEPAIR_GRETA = Dialect(
    "69-value mask of an early facepair file: null FAP 0, then FAP 1..68, MPEG-4 widths",
    (0, *range(1, N_FAPS + 1)),
    True,
)


@lru_cache(maxsize=256)
def mask_layout(
    dialect: Dialect, bits: tuple[int, ...]
) -> tuple[np.ndarray, np.ndarray, int, tuple[tuple[int, int, int], ...]]:
    """For a mask: the kept FAP columns (0-based), their places on the value line, the width,
    and (FAP, place, width) of the masked high-level FAPs 1 and 2.

    Places count from 1 (place 0 is the frame index). Columns are the low-level FAPs 3..68.
    """
    columns, places, high, place = [], [], [], 1
    for fap, bit in zip(dialect.faps, bits, strict=True):
        if not bit:
            continue
        if fap in HIGH_LEVEL_WIDTH:
            high.append((fap, place, dialect.width(fap)))
        elif fap:
            columns.append(fap - 1)
            places.append(place)
        place += dialect.width(fap)
    return (
        np.array(columns, dtype=np.intp),
        np.array(places, dtype=np.intp),
        place - 1,
        tuple(high),
    )


def dialect_of(mask: list[int], early_facepair: bool, path: str, line: int) -> Dialect:
    """The dialect a file's first mask line says by its length (``early_facepair``: the file's
    first comment line is :data:`WRITER_LINE`); any other length raises :class:`InputError`."""
    if len(mask) == N_FAPS:
        return XFACE
    if len(mask) == N_FAPS + 1:
        return EARLY_FACEPAIR_GRETA if early_facepair else GRETA
    raise InputError(
        f"mask line: expected 68 (Xface) or 69 (Greta) values of 0/1, got {len(mask)}",
        path=path,
        line=line,
    )


def count_error(
    dialect: Dialect, bits: tuple[int, ...], got: int, path: str, line: int
) -> InputError:
    """The one line for a value line of the wrong length: what each dialect expects."""
    masked = [fap for fap, bit in zip(dialect.faps, bits, strict=True) if bit]
    if dialect.high_level_widths:
        other = f"Greta, one value each, would expect {len(masked)}"
    else:
        mpeg4 = sum(HIGH_LEVEL_WIDTH.get(fap, 1) for fap in masked)
        other = f"Xface/MPEG-4, 4 for FAP 1 and 6 for FAP 2, would expect {mpeg4}"
    return InputError(
        f"value line: expected the frame index and {mask_layout(dialect, bits)[2]} values for the "
        f"{len(masked)} masked positions ({dialect.name}; {other}), got {got} numbers",
        path=path,
        line=line,
    )
