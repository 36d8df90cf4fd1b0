"""The votes frame built from typed blocks, and the memory the blocks leave behind.

:func:`join_columns` joins the blocks :mod:`app.analysis.vote_values` types into the frame of
:class:`~app.analysis.votes.VotesTable`: a column at a time, written once into its full-length
array (text as a categorical of the values its rows use, choices as a categorical of
``CHOICES``, counts ``Int64``, numbers ``Float64``, flags ``boolean``, times UTC), so at most
one column's pieces and its joined array are held twice. :func:`give_back_freed_memory` hands
the C heap's free pages back to the system after reading; :func:`system_allocator` keeps
Arrow's allocations on that heap while a step runs.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import sys
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from app.trials.rules import CHOICES


def join_columns(blocks: list[dict[str, Any]], columns: Sequence[tuple[str, str]]) -> pd.DataFrame:
    """Join the typed blocks' pieces into one frame, one column at a time, each written once
    into its full-length array; each column's pieces are taken out of ``blocks`` and freed
    as it is built.

    ``columns`` are ``(name, kind)`` in the frame's order; a block holds, per name, a time
    column's ``datetime64[us]`` values, or any other column's codes and one value per code
    (text: ``str``; choice: an index into ``CHOICES``; the rest: a float, NaN when missing).
    """
    out: dict[str, Any] = {}
    for name, kind in columns:
        pieces = [b.pop(name) for b in blocks]
        sizes = [len(p) if kind == "time" else len(p[0]) for p in pieces]
        starts = np.cumsum([0] + sizes)
        column: Any
        if kind == "time":
            joined = np.empty(starts[-1], dtype="datetime64[us]")
            for piece, start in zip(pieces, starts[:-1], strict=False):
                joined[start : start + len(piece)] = piece
            column = pd.DatetimeIndex(joined).tz_localize("UTC")
        elif kind == "text":
            column = _categories(pieces, starts)
        else:
            dtype = np.int8 if kind == "choice" else np.float64
            joined = np.empty(starts[-1], dtype=dtype)
            for (codes, value), start in zip(pieces, starts[:-1], strict=False):
                np.take(
                    value.astype(dtype, copy=False), codes, out=joined[start : start + len(codes)]
                )
            column = (
                pd.Categorical.from_codes(joined, categories=CHOICES)
                if kind == "choice"
                else _masked(joined, kind)
            )
        out[name] = pd.Series(column, copy=False)
        del pieces
        give_back_freed_memory()  # the pieces' pages, before the next column takes new ones
    return pd.DataFrame(out, copy=False)


def _categories(pieces: list[tuple[np.ndarray, np.ndarray]], starts: np.ndarray) -> Any:
    """A text column's pieces (codes into each block's distinct values) as one categorical of
    the values its rows use, categories sorted."""
    cats, inverse = np.unique(
        np.concatenate([d for _, d in pieces] or [np.zeros(0, object)]), return_inverse=True
    )
    small = np.int8 if cats.size < 127 else np.int16 if cats.size < 32767 else np.int32
    inverse = inverse.astype(small)
    codes = np.empty(starts[-1], dtype=small)
    offset = 0
    for (piece, distinct), start in zip(pieces, starts[:-1], strict=False):
        block_codes = inverse[offset : offset + len(distinct)]
        np.take(block_codes, piece, out=codes[start : start + len(piece)])
        offset += len(distinct)
    used = np.bincount(codes, minlength=cats.size) > 0  # those only dropped rows had go
    if not used.all():
        codes = (np.cumsum(used) - 1).astype(small)[codes]
    return pd.Categorical.from_codes(codes, categories=cats[used].astype(object))


def _masked(joined: np.ndarray, kind: str) -> Any:
    """A flag, count or number column (NaN: missing) as pandas' masked array. A column with no
    value at all (an optional one the export leaves empty) gets ``np.zeros``, whose pages the
    system maps only when written: it costs no memory until something writes it."""
    missing = np.isnan(joined)
    if kind == "flag":
        return pd.arrays.BooleanArray(joined == 1.0, missing)
    dtype = np.int64 if kind == "count" else np.float64
    if missing.all():
        values = np.zeros(joined.size, dtype=dtype)
    else:
        joined[missing] = 0.0  # this function's own array (join_columns made it)
        values = joined.astype(dtype, copy=False)
    make = pd.arrays.IntegerArray if kind == "count" else pd.arrays.FloatingArray
    return make(values, missing)


def give_back_freed_memory() -> None:
    """Return the free pages of Arrow's allocator and of the C heap (glibc only) to the system.

    The blocks' many small arrays are freed in between ones still held, and glibc keeps such
    holes for reuse rather than giving them back: without this a 187 MB file held about
    150 MB more than its table needs after reading. ``malloc_trim`` changes no value.
    """
    pa.default_memory_pool().release_unused()  # Arrow's own allocator keeps pages too
    if _LIBC is not None:
        _LIBC.malloc_trim(0)


@contextlib.contextmanager
def system_allocator() -> Iterator[None]:
    """Arrow's allocations on the C heap while the block (or the decorated function) runs,
    and the freed pages given back after it.

    pandas keeps text as Arrow strings, and every string operation (a strip, a comparison,
    a take) allocates from Arrow's default pool; that pool (mimalloc in the wheels) keeps
    what it frees for later, so a run of such operations held the sum of them: the analysis
    of a 2.7 MB ratings file peaked 41 MB above its start, 19 MB on the C heap, which reuses
    the freed blocks. Arrays remember their pool, so those made before or after are unaffected.
    """
    before = pa.default_memory_pool()
    pa.set_memory_pool(pa.system_memory_pool())
    try:
        yield
    finally:
        pa.set_memory_pool(before)
        give_back_freed_memory()


def _glibc() -> Any:
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        return libc if hasattr(libc, "malloc_trim") else None
    except OSError:
        return None


_LIBC = _glibc() if sys.platform.startswith("linux") else None
